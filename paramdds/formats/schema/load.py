"""Loading a JSON Schema file: checked as draft-07, its validator built, its parameters described.

Autoware keeps a hand-written schema beside each parameter file
(``<package>/schema/<name>.schema.json``)::

    {"type": "object",
     "properties": {"/**": {"type": "object",
                            "properties": {"ros__parameters": {"$ref": "#/definitions/x"}}}},
     "definitions": {"x": {"type": "object",
                           "properties": {"rate": {"type": "number", "minimum": 0.0}}}}}

:func:`load_schema` reads one (``$ref``s resolved as :mod:`.resolve` says; its parameters
as :mod:`.describe` maps them). Bad input is a :class:`~paramdds.errors.FileFormatError`
naming the file and the JSON path: not a JSON object, not a valid draft-07 schema, no
envelope, and what :mod:`.resolve` and :mod:`.describe` refuse.
"""

from __future__ import annotations

from pathlib import Path

from .describe import describe
from .enforce import NodeSchema
from .resolve import (
    ENVELOPE,
    Loader,
    check_keywords,
    envelope,
    file_uri,
    format_error,
    json_pointer,
    parse_json,
)

__all__ = ["load_schema", "load_schema_str"]


def load_schema(path: str | Path, *, lenient: bool = False, declare: bool = True) -> NodeSchema:
    """Read a schema file and the parameters it declares (rules in the module doc).

    ``declare=False`` only reads and checks it for validating files (no envelope needed;
    a ``$ref`` is followed only when a file's check needs it)."""
    from ..base import read_file

    return load_schema_str(
        read_file(path), source=str(path), lenient=lenient, base=Path(path), declare=declare
    )


def load_schema_str(
    text: str,
    *,
    source: str = "<string>",
    lenient: bool = False,
    base: Path | None = None,
    declare: bool = True,
) -> NodeSchema:
    """Like :func:`load_schema` for text; ``base`` is the path relative ``$ref`` start from."""
    import jsonschema

    root = parse_json(text, source)
    if not isinstance(root, dict):
        raise format_error(source, "#", f"a schema file holds a JSON object, not {type(root).__name__}")
    try:
        jsonschema.Draft7Validator.check_schema(root)
    except jsonschema.SchemaError as exc:
        where = json_pointer(exc.absolute_path)
        raise format_error(source, where, f"not a valid draft-07 schema: {exc.message}") from None
    except RecursionError:
        raise format_error(source, "#", "not usable: nested too deeply") from None
    check_keywords(root, source, lenient=lenient)
    root_uri = file_uri(base if base is not None else Path.cwd() / "schema.json")
    loader = Loader(root_uri, root, lenient=lenient)
    with_id = root if "$id" in root else {**root, "$id": root_uri}
    validator = jsonschema.Draft7Validator(
        with_id, registry=loader.registry, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER
    )
    if not declare:
        return NodeSchema(source, root, ENVELOPE, lenient=lenient, _validator=validator)
    node_key, params_schema, params_resolver, params_where = envelope(root, loader, source)
    entries, ref_errors = describe(params_schema, params_resolver, params_where, source)
    return NodeSchema(source, root, node_key, entries, ref_errors, lenient=lenient, _validator=validator)
