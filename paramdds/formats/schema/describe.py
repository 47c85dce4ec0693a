"""Mapping a JSON Schema's properties to parameters: names, descriptors and defaults.

The mapping (also in docs/schema.md):

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
  so is one whose default does not read as its type (``"0,262"`` on a ``number``):
  ``default`` is an annotation that no validator judges, so it is a warning naming the
  file, the JSON path and the text, not an error;
* ``description`` is the descriptor's description;
* ``minimum``/``maximum`` (and ``exclusiveMinimum``/``exclusiveMaximum``, whose bound
  itself the schema keeps out, as generate_parameter_library does for ``gt``/``lt``)
  are the descriptor's range, on a number or on the elements of a number array;
* every other keyword (``enum``, ``const``, lengths, item counts, ``uniqueItems``,
  ``required``, ``additionalProperties``, ``dependencies``, ``oneOf``, ``not``…) is
  written into ``additional_constraints`` as text and enforced by the schema.

"""

from __future__ import annotations

import json
import logging
import math
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from ...core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from ...core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from ...errors import FileFormatError, ParamddsError
from .resolve import ANNOTATION_KEYWORDS, VALIDATION_KEYWORDS, format_error, json_pointer, resolve

__all__ = ["MAX_DEPTH", "MAX_PARAMETERS", "MAX_TEXT", "SchemaEntry", "describe"]

log = logging.getLogger(__name__)
T = ParameterType
MAX_PARAMETERS = 10_000  # a schema declaring more is refused (bounded time on pathological files)
MAX_DEPTH = 64  # group nesting
MAX_TEXT = 2000  # characters of a parameter's additional_constraints (and of a violation's message)
_DBL_MAX = sys.float_info.max
_SCALAR_TYPES = {"boolean": T.BOOL, "integer": T.INTEGER, "number": T.DOUBLE, "string": T.STRING}
_ARRAY_TYPES = {
    "boolean": T.BOOL_ARRAY,
    "integer": T.INTEGER_ARRAY,
    "number": T.DOUBLE_ARRAY,
    "string": T.STRING_ARRAY,
}
# keywords the descriptor itself says (besides the description): not repeated in the text
_IN_DESCRIPTOR = frozenset({"type", "description", "default", "minimum", "maximum", "$comment", "title"})
_warned: set[tuple[str, str]] = set()  # (file, JSON path) of each unreadable default warned about


@dataclass(frozen=True, slots=True)
class SchemaEntry:
    """One parameter the schema declares; ``default`` is NOT_SET when it gives none."""

    name: str
    default: ParameterValue
    descriptor: ParameterDescriptor
    pointer: str  # where in which file: "file#/definitions/x/properties/y"


def describe(
    node: Any, resolver: Any, where: str, file: str
) -> tuple[list[SchemaEntry], dict[str, FileFormatError]]:
    """The parameters the schema ``node`` of ``ros__parameters`` declares (rules in the module
    doc), and the properties left undeclared: a ``$ref`` that fails, an error only if a value
    needs it."""
    walk = _Walk(file)
    walk.group(node, resolver, where, "", 0, frozenset())
    return walk.entries, walk.ref_errors


class _Walk:
    def __init__(self, file: str) -> None:
        self.file = file
        self.entries: list[SchemaEntry] = []
        self.ref_errors: dict[str, FileFormatError] = {}

    def group(
        self, node: Any, resolver: Any, where: str, prefix: str, depth: int, seen: frozenset[int]
    ) -> None:
        if depth > MAX_DEPTH:
            raise format_error(self.file, where, f"groups nested deeper than {MAX_DEPTH}")
        if not isinstance(node, dict):
            return  # true/false: no parameters to declare
        if id(node) in seen:
            raise format_error(self.file, where, "a group contains itself (a $ref cycle)")
        seen = seen | {id(node)}
        props = node.get("properties", {})
        if not isinstance(props, dict):
            return
        required = node.get("required", [])
        group_notes = _group_notes(node, prefix)
        for key, sub in props.items():
            name = f"{prefix}.{key}" if prefix else key
            sub_where = where + json_pointer(["properties", key])[1:]
            try:
                leaf, leaf_resolver, leaf_where = resolve(sub, resolver, sub_where, self.file)
            except FileFormatError as exc:
                # resolved lazily, as check-jsonschema does: a reference is an error only when used
                log.info("%s: %r is not declared: %s", self.file, name, exc.message)
                self.ref_errors[name] = exc
                continue
            if _is_group(leaf):
                self.group(leaf, leaf_resolver, leaf_where, name, depth + 1, seen)
            else:
                notes = list(group_notes)
                if isinstance(required, list) and key in required:
                    notes.insert(0, "required")
                self.entries.append(self.leaf(name, leaf, leaf_resolver, leaf_where, notes))
                if len(self.entries) > MAX_PARAMETERS:
                    raise format_error(self.file, where, f"declares more than {MAX_PARAMETERS} parameters")

    def leaf(self, name: str, node: Any, resolver: Any, where: str, notes: list[str]) -> SchemaEntry:
        if not isinstance(node, dict):
            node = {}
        ptype, dynamic, element_schema = _leaf_type(node, resolver, where, self.file)
        description = node.get("description", "")
        description = description if isinstance(description, str) else json.dumps(description)
        int_range, fp_range = _ranges(node, element_schema, ptype)
        text = _constraint_text(node, element_schema, int_range is not None or fp_range is not None)
        constraints = "; ".join([*notes, *([text] if text else [])])
        if len(constraints) > MAX_TEXT:
            constraints = constraints[:MAX_TEXT] + "…"
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
            items, _, _ = resolve(items, resolver, f"{where}/items", file)
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
        # JSON Schema's `default` is an annotation no validator judges (check-jsonschema, and so
        # Autoware's CI, accept "0,262" on a number): warn, and leave the parameter to its files
        if (file, where) not in _warned:
            _warned.add((file, where))
            what = ptype.label if ptype is not None else "parameter value"
            log.warning(
                "%s: %s: the default %s is not a %s (%s); it is ignored: the parameter takes the "
                "parameter file's value, or starts without one (the schema's own rules still apply)",
                file,
                where,
                _show(raw),
                what,
                exc.message,
            )
        return NOT_SET
