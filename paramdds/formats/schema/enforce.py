"""Autoware's JSON Schema (draft-07) parameter files: declaring a node from one, and enforcing it.

Autoware keeps a hand-written schema beside each parameter file
(``<package>/schema/<name>.schema.json``)::

    {"type": "object",
     "properties": {"/**": {"type": "object",
                            "properties": {"ros__parameters": {"$ref": "#/definitions/x"}}}},
     "definitions": {"x": {"type": "object",
                           "properties": {"rate": {"type": "number", "minimum": 0.0}}}}}

:func:`load_schema` reads one (``$ref`` to ``#/definitions/...`` and to other files
relative to the referring file, resolved lazily with ``referencing`` as
check-jsonschema resolves them: a reference nobody needs is never followed) and
:func:`declare_schema` declares the parameters it describes on a table and installs
the schema as the table's whole-node validator, so every later set, atomic set,
delete or declaration that would leave the node invalid is refused with the
schema's own reason. Validation is ``jsonschema``'s ``Draft7Validator`` (with its
format checker, as check-jsonschema), never a validator written here: the verdict
on a node's values is the verdict on the same values written as a parameter file.

Mapping (also in docs/schema.md):

* the parameters are the ``properties`` under the envelope ``<node key>`` >
  ``ros__parameters`` (``"/**"`` in Autoware); a nested object is a group: its
  properties are dotted names (``ndt.max_iterations``);
* ``boolean``/``integer``/``number``/``string`` are bool, integer, double, string;
  an ``array`` whose ``items`` has one of those types is the array of it; an array
  without a typed ``items``, a type list (``["number", "string"]``) or no type is
  **dynamically typed** (any value the schema accepts; the schema refuses the rest);
* a ``number`` holding an integer (``max_iterations: 30``) is a double (``30.0``):
  the table widens integers to doubles, and JSON Schema accepts either;
* ``default`` is the default; one written as a string on another type
  (``"default": "0.5"``, ``"true"``, ``"[1.0, 2.0]"``) is read as a ROS 2 parameter
  file would read that text. A property without a default and without a file value
  is declared without a value (``required`` then refuses the node until it has one);
* ``description`` is the descriptor's description;
* ``minimum``/``maximum`` (and ``exclusiveMinimum``/``exclusiveMaximum``, whose bound
  itself the schema keeps out, as generate_parameter_library does for ``gt``/``lt``)
  are the descriptor's range, on a number or on the elements of a number array;
* every other keyword (``enum``, ``const``, lengths, item counts, ``uniqueItems``,
  ``required``, ``additionalProperties``, ``dependencies``, ``oneOf``, ``not``…) is
  written into ``additional_constraints`` as text and enforced by the schema.

Bad input is a :class:`~paramdds.errors.FileFormatError` naming the file and the
JSON path: not JSON, not an object, not a valid draft-07 schema, a ``$ref`` that
fails when it is needed, a ``$ref`` cycle, a keyword draft-07 does not define
(``lenient=True`` warns instead: it changes nothing in the validation), a default
that is not of its type.
"""

from __future__ import annotations

import json
import logging
import math
import re
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

from ...core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from ...core.table import ParameterTable
from ...core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from ...errors import FileFormatError, ParamddsError

__all__ = [
    "NodeSchema",
    "SchemaEntry",
    "Violation",
    "declare_schema",
    "load_schema",
    "load_schema_str",
    "to_json",
]

log = logging.getLogger(__name__)
T = ParameterType
PARAMS_KEY = "ros__parameters"
ENVELOPE = "/**"
MAX_PARAMETERS = 10_000  # a schema declaring more is refused (bounded time on pathological files)
MAX_DEPTH = 64  # group nesting
_MAX_TEXT = 2000  # characters of additional_constraints per parameter
_DBL_MAX = sys.float_info.max

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
# an object schema with only these checks its key set and each property on its own
_SEPARABLE = frozenset(
    {"type", "properties", "required", "additionalProperties", "patternProperties", "minProperties"}
    | {"maxProperties", "propertyNames"}
    | ANNOTATION_KEYWORDS
)
_SCHEMA_ONE = ("additionalItems", "additionalProperties", "contains", "propertyNames", "if", "then")
_SCHEMA_ONE2 = ("else", "not")
_SCHEMA_LISTS = ("allOf", "anyOf", "oneOf")
_SCALAR_TYPES = {"boolean": T.BOOL, "integer": T.INTEGER, "number": T.DOUBLE, "string": T.STRING}
_ARRAY_TYPES = {
    "boolean": T.BOOL_ARRAY,
    "integer": T.INTEGER_ARRAY,
    "number": T.DOUBLE_ARRAY,
    "string": T.STRING_ARRAY,
}
# keywords the descriptor itself says (besides the description): not repeated in the text
_IN_DESCRIPTOR = frozenset({"type", "description", "default", "minimum", "maximum", "$comment", "title"})


def _pointer(parts: Iterable[object]) -> str:
    return "#/" + "/".join(str(p).replace("~", "~0").replace("/", "~1") for p in parts)


def _error(file: str, where: str, message: str) -> FileFormatError:
    return FileFormatError(f"{where}: {message}" if where else message, file=file)


def _file_uri(path: Path) -> str:
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
                    f"{_pointer((*where, key))}: format {value!r} cannot be enforced here (jsonschema's "
                    f"format checker knows {', '.join(sorted(_formats()))})"
                )
                if not lenient:
                    raise FileFormatError(message + "; --lenient ignores it", file=file)
                log.warning("%s: %s; not enforced (--lenient)", file, message)
            elif key not in VALIDATION_KEYWORDS and key not in ANNOTATION_KEYWORDS:
                message = (
                    f"{_pointer((*where, key))}: unknown keyword {key!r}: draft-07 does not define it, so "
                    "it would validate nothing (a typo, or a later draft's keyword?)"
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


@dataclass(frozen=True, slots=True)
class SchemaEntry:
    """One parameter the schema declares; ``default`` is NOT_SET when it gives none."""

    name: str
    default: ParameterValue
    descriptor: ParameterDescriptor
    pointer: str  # where in which file: "file#/definitions/x/properties/y"


@dataclass(frozen=True, slots=True)
class Violation:
    """One reason the schema refuses a node's values: ``path`` is the dotted parameter path
    (``""`` for the node itself), ``where`` the JSON path in the document checked."""

    path: str
    message: str
    where: str = ""

    def __str__(self) -> str:
        return f"{self.path or '(node)'}: {self.message}"


@dataclass
class NodeSchema:
    """A loaded schema: its parameters (``entries``) and its validator."""

    file: str
    root: dict[str, Any]
    node_key: str
    entries: list[SchemaEntry] = field(default_factory=list)
    # properties left undeclared: a $ref that fails, an error only if a value needs it
    ref_errors: dict[str, FileFormatError] = field(default_factory=dict)
    lenient: bool = False
    _validator: Any = None
    _cache: dict[int, tuple[Any, Any]] = field(default_factory=dict)  # id(sub-schema) -> validators
    _refs: dict[int, tuple[Any, Any, Any]] = field(default_factory=dict)  # id($ref node) -> its target

    # --- validating ----------------------------------------------------------------------

    def document_violations(self, document: object) -> list[Violation]:
        """What the schema says of a whole parameter file (the YAML as plain data):
        check-jsonschema's check. A ``$ref`` that fails here is a FileFormatError."""
        import referencing.exceptions

        try:
            errors = list(self._validator.iter_errors(document))
        except referencing.exceptions.Unresolvable as exc:
            raise _unresolvable(self.file, getattr(exc, "_wrapped", exc)) from None
        except RecursionError:
            raise _error(self.file, "", "the schema recurses without end (a $ref cycle)") from None
        return [_violation(e) for e in sorted(errors, key=_order)]

    def violations(self, values: Mapping[str, ParameterValue]) -> list[Violation]:
        """What the schema says of a node holding ``values`` (unset ones are absent)."""
        return self.document_violations(self.document(values))

    def changed_violations(
        self,
        values: Mapping[str, ParameterValue],
        before: Mapping[str, ParameterValue | None],
        mirror: _Mirror | None = None,
    ) -> list[Violation]:
        """:meth:`violations`, for a node whose values were valid before the names of
        ``before`` changed (``before``: their values then, None when absent).

        The same verdict, found by validating only what the change can affect: along the
        path to each changed name, an object whose keywords are all *separable* (``type``,
        ``properties``, ``required``, ``additionalProperties``, ``patternProperties``,
        ``min/maxProperties``, ``propertyNames``: each checks the key set or one property
        alone) is checked for its key set and descended into; any other subschema (a leaf,
        or an object with ``oneOf``, ``dependencies``, ``not``…) is validated whole by
        jsonschema. Everything off those paths was valid and did not change. ``mirror`` keeps
        the nested document between calls (patched, not rebuilt)."""
        import referencing.exceptions

        names = list(before)
        keys_changed = any(_present(before, n) != _present(values, n) for n in names)
        params = mirror.update(values) if mirror is not None else nest(values)
        document = {self.node_key: {PARAMS_KEY: params}}
        paths = [(self.node_key, PARAMS_KEY, *n.split(".")) for n in names]
        for name in names:
            value = values.get(name)
            if value is not None and value.type is not T.NOT_SET and not _nested_at(params, name.split(".")):
                return self.document_violations(document)  # a dotted key (a name also a prefix)
        root, resolver = self._validator.schema, self._validator._resolver
        try:
            if mirror is None or keys_changed:
                errors = self._descend(root, resolver, document, (), paths, 0, keys_changed)
            else:  # values only: each name's plan (the subschemas validated whole) is fixed
                steps: dict[tuple[Any, ...], Any] = {}
                for name, path in zip(names, paths, strict=True):
                    plan = mirror.plans.get(name)
                    if plan is None:
                        plan = mirror.plans[name] = []
                        self._descend(root, resolver, document, (), [path], 0, False, plan)
                    steps.update(plan)
                errors = [
                    (prefix, e)
                    for prefix, whole in steps.items()
                    for e in whole.iter_errors(_at(document, prefix))
                ]
        except referencing.exceptions.Unresolvable as exc:
            raise _unresolvable(self.file, getattr(exc, "_wrapped", exc)) from None
        except RecursionError:
            raise _error(self.file, "", "the schema recurses without end (a $ref cycle)") from None
        return [_violation(e, prefix) for prefix, e in sorted(errors, key=lambda pe: _order(pe[1], pe[0]))]

    def _validators_for(self, node: Any, resolver: Any) -> tuple[Any, Any]:
        """(the whole subschema's validator, its key-set-only validator), cached per subschema."""
        cached = self._cache.get(id(node))
        if cached is not None and cached[0].schema is node:
            return cached
        whole = self._validator.evolve(schema=node, _resolver=resolver)
        reduced = None
        if isinstance(node, dict):
            keyset = ("type", "required", "minProperties", "maxProperties", "propertyNames")
            keys = {k: node[k] for k in keyset if k in node}
            if "additionalProperties" in node:
                keys["properties"] = dict.fromkeys(node.get("properties", {}), True)
                keys["patternProperties"] = dict.fromkeys(node.get("patternProperties", {}), True)
                keys["additionalProperties"] = node["additionalProperties"] is not False
            reduced = self._validator.evolve(schema=keys, _resolver=resolver)
        self._cache[id(node)] = (whole, reduced)
        return whole, reduced

    def _descend(
        self,
        node: Any,
        resolver: Any,
        instance: Any,
        prefix: tuple[Any, ...],
        paths: list[tuple[str, ...]],
        hops: int,
        keys_changed: bool,
        plan: list[tuple[tuple[Any, ...], Any]] | None = None,
    ) -> list[tuple[tuple[Any, ...], Any]]:
        """The errors along ``paths`` (rules in :meth:`changed_violations`); with ``plan``,
        records the (prefix, validator) pairs it would run instead of running them."""
        while isinstance(node, dict) and "$ref" in node:  # draft-07: $ref replaces its siblings
            hops += 1
            if hops > 200:
                raise RecursionError
            cached = self._refs.get(id(node))
            if cached is None or cached[0] is not node:
                resolved = resolver.lookup(node["$ref"])
                cached = self._refs[id(node)] = (node, resolved.contents, resolved.resolver)
            node, resolver = cached[1], cached[2]
        whole, reduced = self._validators_for(node, resolver)
        separable = isinstance(node, dict) and isinstance(instance, dict) and _SEPARABLE.issuperset(node)
        if not separable or any(not p for p in paths):
            if plan is not None:
                plan.append((prefix, whole))
                return []
            return [(prefix, e) for e in whole.iter_errors(instance)]
        # the key-set checks: only when a name comes or goes (values alone leave them as they were)
        out = [(prefix, e) for e in reduced.iter_errors(instance)] if keys_changed else []
        children: dict[str, list[tuple[str, ...]]] = {}
        for p in paths:
            children.setdefault(p[0], []).append(p[1:])
        props = node.get("properties", {})
        patterns = node.get("patternProperties", {})
        for key, rest in children.items():
            if key not in instance:
                continue  # deleted: the key-set check covers it
            subs = [props[key]] if key in props else []
            subs += [sub for pattern, sub in patterns.items() if re.search(pattern, key)]
            extra = node.get("additionalProperties")
            if not subs and isinstance(extra, dict):
                subs = [extra]
            for sub in subs:
                out += self._descend(
                    sub, resolver, instance[key], (*prefix, key), rest, hops, keys_changed, plan
                )
        return out

    def document(self, values: Mapping[str, ParameterValue]) -> dict[str, Any]:
        """``values`` as the parameter file check-jsonschema would read: the envelope, nested."""
        return {self.node_key: {PARAMS_KEY: nest(values)}}

    def node_validator(
        self,
    ) -> Callable[
        [Mapping[str, ParameterValue], Mapping[str, ParameterValue | None]], tuple[str, str] | None
    ]:
        """The table's whole-node validator: the first violation, blamed on the touched name
        it concerns (a name at or under its path), else on none of them."""

        trusted = [False]  # the state last accepted was checked whole: later checks are incremental
        mirror = _Mirror()

        def check(
            values: Mapping[str, ParameterValue], before: Mapping[str, ParameterValue | None]
        ) -> tuple[str, str] | None:
            names = list(before)
            try:
                if trusted[0]:
                    found = self.changed_violations(values, before, mirror)
                else:
                    found = self.violations(values)
                    trusted[0] = not found
            except ParamddsError as exc:
                return "", f"schema {self.file}: {exc.message}"
            if not found:
                return None
            v = found[0]
            blamed = next((n for n in names if _concerns(v.path, n)), "")
            reason = f"{v.path}: {v.message}" if v.path else v.message
            return blamed, f"schema: {reason}"

        return check


def _at(document: Any, prefix: tuple[Any, ...]) -> Any:
    for key in prefix:
        document = document[key]
    return document


def _present(values: Mapping[str, ParameterValue | None], name: str) -> bool:
    value = values.get(name)
    return value is not None and value.type is not T.NOT_SET


def _nested_at(params: dict[str, Any], parts: list[str]) -> bool:
    node: Any = params
    for part in parts:
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True


def _concerns(path: str, name: str) -> bool:
    """Whether a violation at ``path`` (``a.b``, ``a.b[1]``) concerns the parameter ``name``."""
    return (
        not path or name == path or name.startswith(path + ".") or path.startswith((name + ".", name + "["))
    )


def _order(error: Any, prefix: tuple[Any, ...] = ()) -> tuple[int, str]:
    parts = [*prefix, *error.absolute_path]
    return (len(parts), ".".join(str(p) for p in parts))


def _violation(error: Any, prefix: tuple[Any, ...] = ()) -> Violation:
    parts = [*prefix, *error.absolute_path]
    where = "$" + "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts)
    path_parts = (
        [str(p) if not isinstance(p, int) else f"[{p}]" for p in parts[2:]] if len(parts) >= 2 else []
    )
    dotted = ".".join(path_parts).replace(".[", "[")
    message = str(error.message)
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        known = error.schema.get("properties", {}) if isinstance(error.schema, dict) else {}
        extra = [k for k in error.instance if k not in known]
        if len(extra) == 1 and len(parts) >= 2:
            dotted = f"{dotted}.{extra[0]}" if dotted else str(extra[0])
    if error.context and error.validator in ("oneOf", "anyOf"):
        branches: dict[int, list[str]] = {}
        for sub in error.context:
            index = sub.schema_path[0] if sub.schema_path else 0
            branches.setdefault(int(index), []).append(str(sub.message))
        detail = "; ".join(f"branch {i + 1}: {', '.join(m)}" for i, m in sorted(branches.items()))
        message = f"{message} ({detail})"
    if len(message) > _MAX_TEXT:
        message = message[:_MAX_TEXT] + "…"
    return Violation(dotted, message, where)


def _unresolvable(file: str, exc: Exception) -> FileFormatError:
    ref = getattr(exc, "ref", "")
    cause = exc.__cause__
    if isinstance(cause, FileFormatError):
        return cause
    return _error(file, "", f"$ref {ref!r} cannot be resolved: {_brief(exc)}")


def _brief(exc: Exception) -> str:
    """referencing's message without the whole document it quotes."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    cut = " does not exist within "
    if cut in text:
        text = text.split(cut, 1)[0] + " does not exist"
    if len(text) > 300:
        text = text[:300] + "…"
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def to_json(value: ParameterValue) -> Any:
    """A parameter value as JSON data (NOT_SET: None)."""
    v = value.value
    if isinstance(v, (tuple, list, bytes)):
        return list(v)
    return v


class _Mirror:
    """The nested document of the values last checked, patched for what changed since."""

    def __init__(self) -> None:
        self.values: dict[str, ParameterValue] = {}
        self.params: dict[str, Any] | None = None
        # name -> the (prefix, validator) a change of its value alone runs
        self.plans: dict[str, list[tuple[tuple[Any, ...], Any]]] = {}

    def update(self, values: Mapping[str, ParameterValue]) -> dict[str, Any]:
        old = self.values
        params = self.params
        if params is not None:
            changed = [n for n, v in values.items() if old.get(n) is not v]
            changed += [n for n in old if n not in values]
            if len(changed) * 4 > len(values) or not all(
                self._patch(params, n, values.get(n)) for n in changed
            ):
                params = None
        if params is None:
            params = nest(values)
        self.params, self.values = params, dict(values)
        return params

    @staticmethod
    def _patch(params: dict[str, Any], name: str, value: ParameterValue | None) -> bool:
        """Write one value in place; False when only a rebuild can (a name that is a prefix)."""
        parts = name.split(".")
        chain = [params]
        node = params
        for part in parts[:-1]:
            child = node.get(part)
            if child is None:
                if value is None or value.type is T.NOT_SET:
                    return True  # nothing there to delete
                child = node[part] = {}
            elif not isinstance(child, dict):
                return False
            chain.append(child)
            node = child
        leaf = parts[-1]
        if isinstance(node.get(leaf), dict):
            return False
        if value is None or value.type is T.NOT_SET:
            node.pop(leaf, None)
            for parent, part, child in zip(
                reversed(chain[:-1]), reversed(parts[:-1]), reversed(chain[1:]), strict=True
            ):
                if child:
                    break
                del parent[part]  # nest() writes no empty group
        else:
            node[leaf] = to_json(value)
        return True


def nest(values: Mapping[str, ParameterValue]) -> dict[str, Any]:
    """Dotted names as nested objects; unset values are left out. A name that is both a value
    and a prefix keeps the longer names as dotted keys (as a dump writes them)."""
    out: dict[str, Any] = {}
    for name in sorted(values):
        value = values[name]
        if value.type is T.NOT_SET:
            continue
        parts = name.split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.get(part)
            if child is None:
                child = node[part] = {}
            elif not isinstance(child, dict):
                node[".".join(parts[i:])] = to_json(value)
                break
            node = child
        else:
            node[parts[-1]] = to_json(value)
    return out


# --- loading ---------------------------------------------------------------------------------


class _Loader:
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
        raise _error(source, "#", f"a schema file holds a JSON object, not {type(root).__name__}")
    try:
        jsonschema.Draft7Validator.check_schema(root)
    except jsonschema.SchemaError as exc:
        where = _pointer(exc.absolute_path)
        raise _error(source, where, f"not a valid draft-07 schema: {exc.message}") from None
    except RecursionError:
        raise _error(source, "#", "not usable: nested too deeply") from None
    check_keywords(root, source, lenient=lenient)
    root_uri = _file_uri(base if base is not None else Path.cwd() / "schema.json")
    loader = _Loader(root_uri, root, lenient=lenient)
    with_id = root if "$id" in root else {**root, "$id": root_uri}
    validator = jsonschema.Draft7Validator(
        with_id, registry=loader.registry, format_checker=jsonschema.Draft7Validator.FORMAT_CHECKER
    )
    if not declare:
        return NodeSchema(source, root, ENVELOPE, lenient=lenient, _validator=validator)
    node_key, params_schema, params_resolver, params_where = _envelope(root, loader, source)
    schema = NodeSchema(source, root, node_key, lenient=lenient, _validator=validator)
    _Walk(source, schema).group(params_schema, params_resolver, params_where, "", 0, frozenset())
    return schema


def _resolve(
    schema: Any, resolver: Any, where: str, file: str, seen: frozenset[int] = frozenset()
) -> tuple[Any, Any, str]:
    """Follow ``$ref`` (draft-07: its siblings are ignored) until a schema without one."""
    import referencing.exceptions

    hops = 0
    while isinstance(schema, dict) and "$ref" in schema:
        ref = schema["$ref"]
        if not isinstance(ref, str):
            raise _error(file, where, "$ref must be a string")
        try:
            resolved = resolver.lookup(ref)
        except referencing.exceptions.Unresolvable as exc:
            cause = exc.__cause__ or exc.__context__
            if isinstance(cause, FileFormatError):
                raise cause from None
            raise _error(file, where, f"$ref {ref!r} cannot be resolved: {_brief(exc)}") from None
        hops += 1
        if id(resolved.contents) in seen or hops > 100:
            raise _error(file, where, f"$ref {ref!r} is a cycle: it leads back to itself")
        seen = seen | {id(resolved.contents)}
        schema, resolver = resolved.contents, resolved.resolver
        where = f"{where} -> {ref}"  # the path as followed, for errors
    return schema, resolver, where


def _envelope(root: dict[str, Any], loader: _Loader, file: str) -> tuple[str, Any, Any, str]:
    """The node key (``/**``) and the schema of its ``ros__parameters``."""
    top, resolver, where = _resolve(root, loader.resolver, "#", file)
    esc = _pointer
    props = top.get("properties") if isinstance(top, dict) else None
    if not isinstance(props, dict) or not props:
        raise _error(
            file,
            where,
            f"no node key: expected properties {{'{ENVELOPE}': {{'properties': "
            f"{{'{PARAMS_KEY}': ...}}}}}} (Autoware's envelope)",
        )
    keys = [ENVELOPE] if ENVELOPE in props else list(props)
    for key in keys:
        node, node_resolver, node_where = _resolve(
            props[key], resolver, f"{where}{esc(['properties', key])[1:]}", file
        )
        inner = node.get("properties") if isinstance(node, dict) else None
        if isinstance(inner, dict) and PARAMS_KEY in inner:
            params, params_resolver, params_where = _resolve(
                inner[PARAMS_KEY], node_resolver, f"{node_where}/properties/{PARAMS_KEY}", file
            )
            return key, params, params_resolver, params_where
    raise _error(file, where, f"no node key holds '{PARAMS_KEY}' (Autoware's envelope: '{ENVELOPE}')")


class _Walk:
    def __init__(self, file: str, schema: NodeSchema) -> None:
        self.file = file
        self.schema = schema

    def group(
        self, node: Any, resolver: Any, where: str, prefix: str, depth: int, seen: frozenset[int]
    ) -> None:
        if depth > MAX_DEPTH:
            raise _error(self.file, where, f"groups nested deeper than {MAX_DEPTH}")
        if not isinstance(node, dict):
            return  # true/false: no parameters to declare
        if id(node) in seen:
            raise _error(self.file, where, "a group contains itself (a $ref cycle)")
        seen = seen | {id(node)}
        props = node.get("properties", {})
        if not isinstance(props, dict):
            return
        required = node.get("required", [])
        group_notes = _group_notes(node, prefix)
        for key, sub in props.items():
            name = f"{prefix}.{key}" if prefix else key
            sub_where = where + _pointer(["properties", key])[1:]
            try:
                leaf, leaf_resolver, leaf_where = _resolve(sub, resolver, sub_where, self.file)
            except FileFormatError as exc:
                # resolved lazily, as check-jsonschema does: a reference is an error only when used
                log.info("%s: %r is not declared: %s", self.file, name, exc.message)
                self.schema.ref_errors[name] = exc
                continue
            if _is_group(leaf):
                self.group(leaf, leaf_resolver, leaf_where, name, depth + 1, seen)
            else:
                notes = list(group_notes)
                if isinstance(required, list) and key in required:
                    notes.insert(0, "required")
                self.schema.entries.append(self.leaf(name, leaf, leaf_resolver, leaf_where, notes))
                if len(self.schema.entries) > MAX_PARAMETERS:
                    raise _error(self.file, where, f"declares more than {MAX_PARAMETERS} parameters")

    def leaf(self, name: str, node: Any, resolver: Any, where: str, notes: list[str]) -> SchemaEntry:
        if not isinstance(node, dict):
            node = {}
        ptype, dynamic, element_schema = _leaf_type(node, resolver, where, self.file)
        description = node.get("description", "")
        description = description if isinstance(description, str) else json.dumps(description)
        int_range, fp_range = _ranges(node, element_schema, ptype)
        text = _constraint_text(node, element_schema, int_range is not None or fp_range is not None)
        constraints = "; ".join([*notes, *([text] if text else [])])
        if len(constraints) > _MAX_TEXT:
            constraints = constraints[:_MAX_TEXT] + "…"
        default = NOT_SET
        if "default" in node and node["default"] is not None:
            default = _default(node["default"], None if dynamic else ptype, f"{where}/default", self.file)
        descriptor = ParameterDescriptor(
            name=name,
            type=T.NOT_SET if dynamic else ptype,
            description=description,
            additional_constraints=constraints,
            dynamic_typing=dynamic,
            integer_range=int_range,
            floating_point_range=fp_range,
        )
        return SchemaEntry(name, default, descriptor, f"{self.file}{where}")


def _is_group(node: Any) -> bool:
    if not isinstance(node, dict):
        return False
    kind = node.get("type")
    return kind == "object" or (kind is None and isinstance(node.get("properties"), dict))


def _leaf_type(node: dict[str, Any], resolver: Any, where: str, file: str) -> tuple[ParameterType, bool, Any]:
    """(type, dynamically typed, the items' schema for an array)."""
    kind = node.get("type")
    if kind in _SCALAR_TYPES:
        return _SCALAR_TYPES[kind], False, None
    if kind == "array":
        items = node.get("items")
        if isinstance(items, dict):
            items, _, _ = _resolve(items, resolver, f"{where}/items", file)
            if isinstance(items, dict) and items.get("type") in _ARRAY_TYPES:
                return _ARRAY_TYPES[items["type"]], False, items
    return T.NOT_SET, True, None


def _ranges(
    node: dict[str, Any], element: Any, ptype: ParameterType
) -> tuple[IntegerRange | None, FloatingPointRange | None]:
    """minimum/maximum (and the exclusive ones, whose bound the schema keeps out) as a range."""
    source = element if ptype in (T.INTEGER_ARRAY, T.DOUBLE_ARRAY) else node
    number = {T.INTEGER: T.INTEGER, T.DOUBLE: T.DOUBLE, T.INTEGER_ARRAY: T.INTEGER, T.DOUBLE_ARRAY: T.DOUBLE}
    if ptype not in number or not isinstance(source, dict):
        return None, None

    def bound(*keys: str) -> float | None:
        found = [source[k] for k in keys if _is_number(source.get(k))]
        return None if not found else (max(found) if keys[0] == "minimum" else min(found))

    lo, hi = bound("minimum", "exclusiveMinimum"), bound("maximum", "exclusiveMaximum")
    if lo is None and hi is None:
        return None, None
    if number[ptype] is T.INTEGER:
        ilo = INT64_MIN if lo is None else max(INT64_MIN, math.ceil(lo))
        ihi = INT64_MAX if hi is None else min(INT64_MAX, math.floor(hi))
        return IntegerRange(ilo, ihi), None
    return None, FloatingPointRange(
        -_DBL_MAX if lo is None else float(lo), _DBL_MAX if hi is None else float(hi)
    )


def _is_number(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _show(x: object) -> str:
    return json.dumps(x, ensure_ascii=False, separators=(", ", ": "))


def _constraint_text(node: dict[str, Any], element: Any, has_range: bool) -> str:
    """The keywords the descriptor's fields do not say, as text (enforced by the schema)."""
    parts = list(_keyword_texts(node, skip_bounds=has_range and element is None))
    if isinstance(element, dict):
        inner = list(_keyword_texts(element, skip_bounds=has_range))
        if inner:
            parts.append("each item: " + ", ".join(inner))
    return ", ".join(parts)


def _keyword_texts(node: dict[str, Any], *, skip_bounds: bool) -> Iterator[str]:
    simple = {
        "exclusiveMinimum": "> {}",
        "exclusiveMaximum": "< {}",
        "minimum": ">= {}",
        "maximum": "<= {}",
        "minLength": "length >= {}",
        "maxLength": "length <= {}",
        "minItems": "at least {} items",
        "maxItems": "at most {} items",
        "multipleOf": "a multiple of {}",
        "pattern": "matches {}",
        "format": "format {}",
    }
    for key, value in node.items():
        if key in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum") and skip_bounds:
            if key.startswith("exclusive"):
                yield simple[key].format(_show(value))
            continue
        if key in _IN_DESCRIPTOR or key in ANNOTATION_KEYWORDS or key == "items":
            continue
        if key in simple:
            yield simple[key].format(_show(value))
        elif key == "enum":
            yield f"one of {_show(value)}"
        elif key == "const":
            yield f"= {_show(value)}"
        elif key == "uniqueItems":
            if value is True:
                yield "items unique"
        elif key in VALIDATION_KEYWORDS:
            yield f"{key}: {_show(value)}"


def _group_notes(node: dict[str, Any], prefix: str) -> list[str]:
    """What a group's own keywords say, noted on each of its parameters."""
    where = f"group '{prefix}'" if prefix else "the node"
    notes = []
    if node.get("additionalProperties") is False:
        notes.append(f"{where} has no other parameters")
    for key in ("dependencies", "oneOf", "anyOf", "allOf", "not", "if", "then", "else", "minProperties"):
        if key in node:
            notes.append(f"{where}: {key} {_show(node[key])}")
    return notes


def _default(raw: object, ptype: ParameterType | None, where: str, file: str) -> ParameterValue:
    """A schema default as a value: JSON data, or a string read as a parameter file's text."""
    from ..scalar import parse_cli_value

    try:
        if isinstance(raw, str) and ptype is not T.STRING:
            return parse_cli_value(raw, ptype)
        if isinstance(raw, list) and not raw:  # untyped array: an empty string_array
            return ParameterValue(ptype if ptype is not None and ptype.is_array else T.STRING_ARRAY, ())
        value = ParameterValue.from_python(raw)
        return value.coerce(ptype, name="default") if ptype is not None else value
    except ParamddsError as exc:
        what = ptype.label if ptype is not None else "parameter value"
        raise _error(file, where, f"the default {_show(raw)} is not a {what}: {exc.message}") from None


# --- declaring ---------------------------------------------------------------------------------


def declare_schema(
    table: ParameterTable,
    schema: NodeSchema,
    values: Mapping[str, ParameterValue] | None = None,
    *,
    lenient: bool = False,
) -> list[str]:
    """Declare the schema's parameters on ``table`` (overrides given to the table win, as
    with a spec) and install the schema as its whole-node validator.

    ``values`` are every value the parameter files give (those the schema does not declare
    count too: ``additionalProperties: false`` refuses them). A parameter the files do
    not give takes the schema's default, unless that default is what makes the node
    invalid (``default`` is only an annotation in JSON Schema: a ``oneOf`` branch may
    need the parameter absent); it is then declared without a value. When the file
    values break the schema, nothing is declared and a FileFormatError names each
    violation; with ``lenient`` the file values at fault are left out instead and the
    returned lines say so.
    """
    given = dict(values or {})
    for name, exc in schema.ref_errors.items():
        if name in given or any(n.startswith(name + ".") for n in given):
            raise exc  # the reference is needed now
    declared = {e.name: e for e in schema.entries}
    chosen: dict[str, ParameterValue] = {}
    for e in schema.entries:
        override = table.override(e.name)
        chosen[e.name] = e.default if override is None else override
    from_file = {n for n in declared if table.has_override(n)}
    changed: set[str] = set()  # declared with another value than the table would choose
    notes: list[str] = []
    for _ in range(2 * len(declared) + 1):
        state = {**{n: v for n, v in given.items() if n not in declared}, **chosen}
        state = {n: _as_stored(v, declared.get(n), n) for n, v in state.items()}
        found = [v for v in schema.violations(state)]
        if not found:
            break

        def concerned(name: str, found: list[Violation] = found) -> bool:
            return any(v.path and _concerns(v.path, name) for v in found)

        defaults = [n for n, v in chosen.items() if n not in from_file and v.type is not T.NOT_SET]
        unset = [n for n in defaults if concerned(n)]
        if unset:
            for name in unset:
                chosen[name] = NOT_SET
                changed.add(name)
                log.info("%s: %r starts without a value: its default breaks the schema", schema.file, name)
            continue
        at_fault = [n for n in sorted(from_file) if concerned(n)]
        if not lenient or not at_fault:
            lines = "; ".join(str(v) for v in found)
            raise FileFormatError(f"the parameters break the schema: {lines}", file=schema.file)
        for name in at_fault:
            from_file.discard(name)
            chosen[name] = declared[name].default
            changed.add(name)
            why = "; ".join(str(v) for v in found if _concerns(v.path, name))
            notes.append(f"--lenient: {name!r} starts without the file's value ({why})")
    else:  # pragma: no cover - each name changes at most twice
        raise FileFormatError("the parameters break the schema", file=schema.file)
    table.declare_from([(e.name, e.default, e.descriptor) for e in schema.entries if e.name not in changed])
    for e in schema.entries:
        if e.name in changed:
            table.declare(e.name, chosen[e.name], e.descriptor, ignore_override=True)
    table.set_node_validator(schema.node_validator())
    return notes


def _as_stored(value: ParameterValue, entry: SchemaEntry | None, name: str) -> ParameterValue:
    """A file value as the table stores it (an integer for a double parameter is widened)."""
    if entry is None or entry.descriptor.dynamic_typing or value.type is T.NOT_SET:
        return value
    try:
        return value.coerce(entry.descriptor.type, name=name)
    except ParamddsError:
        return value  # the table refuses it when it is declared, with the type's reason
