"""Reading a JSON Schema's documents and following their ``$ref``s, draft-07's keywords checked.

A ``$ref`` to ``#/definitions/...`` or to another file (relative to the referring
file) is resolved lazily with ``referencing``, as check-jsonschema resolves it: a file
is read, and its keywords checked, when a reference first needs it, and a reference
nobody needs is never followed. References to anything but files are refused.

Bad input is a :class:`~paramdds.errors.FileFormatError` naming the file and the JSON
path: not JSON, a ``$ref`` that fails when it is needed, a ``$ref`` cycle, a keyword
draft-07 does not define (``lenient=True`` warns instead: it changes nothing in the
validation).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

from ...errors import FileFormatError

__all__ = [
    "ANNOTATION_KEYWORDS",
    "ENVELOPE",
    "PARAMS_KEY",
    "VALIDATION_KEYWORDS",
    "Loader",
    "brief",
    "check_keywords",
    "envelope",
    "file_uri",
    "format_error",
    "json_pointer",
    "parse_json",
    "resolve",
]

log = logging.getLogger(__name__)
PARAMS_KEY = "ros__parameters"
ENVELOPE = "/**"

# draft-07's keywords: those that validate, and those that only annotate
VALIDATION_KEYWORDS = frozenset(
    {"$ref", "type", "enum", "const", "multipleOf", "maximum", "exclusiveMaximum", "minimum"}
    | {"exclusiveMinimum", "maxLength", "minLength", "pattern", "items", "additionalItems"}
    | {"maxItems", "minItems", "uniqueItems", "contains", "maxProperties", "minProperties"}
    | {"required", "properties", "patternProperties", "additionalProperties", "dependencies"}
    | {"propertyNames", "if", "then", "else", "allOf", "anyOf", "oneOf", "not", "format"}
)
ANNOTATION_KEYWORDS = frozenset(
    {"$schema", "$id", "$comment", "title", "description", "default", "examples", "readOnly"}
    | {"writeOnly", "definitions", "contentMediaType", "contentEncoding"}
)
_SCHEMA_MAPS = ("properties", "patternProperties", "definitions")
_SCHEMA_ONE = ("additionalItems", "additionalProperties", "contains", "propertyNames", "if", "then")
_SCHEMA_ONE2 = ("else", "not")
_SCHEMA_LISTS = ("allOf", "anyOf", "oneOf")


def json_pointer(parts: Iterable[object]) -> str:
    """A JSON path as errors show it: ``#/properties/a~1b``."""
    return "#/" + "/".join(str(p).replace("~", "~0").replace("/", "~1") for p in parts)


def format_error(file: str, where: str, message: str) -> FileFormatError:
    """A FileFormatError naming the file and, before the message, the JSON path."""
    return FileFormatError(f"{where}: {message}" if where else message, file=file)


def file_uri(path: Path) -> str:
    """The ``file:`` URI a schema file is known by in the registry."""
    return path.resolve().as_uri()


def _uri_path(uri: str) -> Path:
    return Path(unquote(urlsplit(uri).path))


def parse_json(text: str, file: str) -> Any:
    """A JSON document; FileFormatError with the line on a syntax error."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"not JSON: {exc.msg} (column {exc.colno})", file=file, line=exc.lineno
        ) from None
    except RecursionError:
        raise FileFormatError("not usable JSON: nested too deeply", file=file) from None


def check_keywords(schema: Any, file: str, path: Sequence[object] = (), *, lenient: bool = False) -> None:
    """Refuse a keyword draft-07 does not define (it would be silently ignored): FileFormatError
    with its JSON path, or a warning when ``lenient``."""
    stack: list[tuple[Any, tuple[object, ...]]] = [(schema, tuple(path))]
    while stack:
        node, where = stack.pop()
        if isinstance(node, bool):
            continue
        if not isinstance(node, dict):
            continue  # the metaschema check reports it with its path
        for key, value in node.items():
            if key in _SCHEMA_MAPS and isinstance(value, dict):
                stack.extend((v, (*where, key, k)) for k, v in value.items())
            elif key == "dependencies" and isinstance(value, dict):
                stack.extend((v, (*where, key, k)) for k, v in value.items() if isinstance(v, (dict, bool)))
            elif key in _SCHEMA_ONE or key in _SCHEMA_ONE2:
                stack.append((value, (*where, key)))
            elif key in _SCHEMA_LISTS and isinstance(value, list):
                stack.extend((v, (*where, key, i)) for i, v in enumerate(value))
            elif key == "items":
                if isinstance(value, list):
                    stack.extend((v, (*where, key, i)) for i, v in enumerate(value))
                else:
                    stack.append((value, (*where, key)))
            elif key == "format" and isinstance(value, str) and value not in _formats():
                message = (
                    f"{json_pointer((*where, key))}: format {value!r} cannot be enforced here (jsonschema's "
                    f"format checker knows {', '.join(sorted(_formats()))})"
                )
                if not lenient:
                    raise FileFormatError(message + "; --lenient ignores it", file=file)
                log.warning("%s: %s; not enforced (--lenient)", file, message)
            elif key not in VALIDATION_KEYWORDS and key not in ANNOTATION_KEYWORDS:
                message = (
                    f"{json_pointer((*where, key))}: unknown keyword {key!r}: draft-07 does not define it, "
                    "so it would validate nothing (a typo, or a later draft's keyword?)"
                )
                if not lenient:
                    raise FileFormatError(message + "; --lenient ignores it", file=file)
                log.warning("%s: %s; ignored (--lenient)", file, message)


def _formats() -> frozenset[str]:
    import jsonschema

    return frozenset(jsonschema.Draft7Validator.FORMAT_CHECKER.checkers)


def _load_document(path: Path, *, lenient: bool) -> Any:
    from ..base import read_file

    name = str(path)
    doc = parse_json(read_file(path), name)
    check_keywords(doc, name, lenient=lenient)
    return doc


class Loader:
    """The registry of one schema: files are read (and their keywords checked) when first needed."""

    def __init__(self, root_uri: str, root: dict[str, Any], *, lenient: bool) -> None:
        from referencing import Registry, Resource
        from referencing.jsonschema import DRAFT7

        self.lenient = lenient

        loaded: dict[str, Resource[Any]] = {}

        def retrieve(uri: str) -> Resource[Any]:
            if not uri.startswith("file:"):
                raise FileFormatError(f"$ref to {uri!r}: paramdds resolves references to files only")
            if uri not in loaded:  # read once, when first needed
                contents = _load_document(_uri_path(uri), lenient=lenient)
                loaded[uri] = Resource.from_contents(contents, default_specification=DRAFT7)
            return loaded[uri]

        self.registry: Registry[Any] = Registry(retrieve=retrieve).with_resource(  # type: ignore[call-arg]
            root_uri, DRAFT7.create_resource(root)
        )
        self.resolver = self.registry.resolver(base_uri=root_uri)


def resolve(
    schema: Any, resolver: Any, where: str, file: str, seen: frozenset[int] = frozenset()
) -> tuple[Any, Any, str]:
    """Follow ``$ref`` (draft-07: its siblings are ignored) until a schema without one."""
    import referencing.exceptions

    hops = 0
    while isinstance(schema, dict) and "$ref" in schema:
        ref = schema["$ref"]
        if not isinstance(ref, str):
            raise format_error(file, where, "$ref must be a string")
        try:
            resolved = resolver.lookup(ref)
        except referencing.exceptions.Unresolvable as exc:
            cause = exc.__cause__ or exc.__context__
            if isinstance(cause, FileFormatError):
                raise cause from None
            raise format_error(file, where, f"$ref {ref!r} cannot be resolved: {brief(exc)}") from None
        hops += 1
        if id(resolved.contents) in seen or hops > 100:
            raise format_error(file, where, f"$ref {ref!r} is a cycle: it leads back to itself")
        seen = seen | {id(resolved.contents)}
        schema, resolver = resolved.contents, resolved.resolver
        where = f"{where} -> {ref}"  # the path as followed, for errors
    return schema, resolver, where


def envelope(root: dict[str, Any], loader: Loader, file: str) -> tuple[str, Any, Any, str]:
    """The node key (``/**``) and the schema of its ``ros__parameters``."""
    top, resolver, where = resolve(root, loader.resolver, "#", file)
    esc = json_pointer
    props = top.get("properties") if isinstance(top, dict) else None
    if not isinstance(props, dict) or not props:
        raise format_error(
            file,
            where,
            f"no node key: expected properties {{'{ENVELOPE}': {{'properties': "
            f"{{'{PARAMS_KEY}': ...}}}}}} (Autoware's envelope)",
        )
    keys = [ENVELOPE] if ENVELOPE in props else list(props)
    for key in keys:
        node, node_resolver, node_where = resolve(
            props[key], resolver, f"{where}{esc(['properties', key])[1:]}", file
        )
        inner = node.get("properties") if isinstance(node, dict) else None
        if isinstance(inner, dict) and PARAMS_KEY in inner:
            params, params_resolver, params_where = resolve(
                inner[PARAMS_KEY], node_resolver, f"{node_where}/properties/{PARAMS_KEY}", file
            )
            return key, params, params_resolver, params_where
    raise format_error(file, where, f"no node key holds '{PARAMS_KEY}' (Autoware's envelope: '{ENVELOPE}')")


def brief(exc: Exception) -> str:
    """referencing's message without the whole document it quotes."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    cut = " does not exist within "
    if cut in text:
        text = text.split(cut, 1)[0] + " does not exist"
    if len(text) > 300:
        text = text[:300] + "…"
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
