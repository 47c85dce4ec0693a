"""Deriving a draft-07 JSON Schema, in Autoware's envelope, from descriptors.

:func:`derive_schema` takes ``(name, value, descriptor)`` triples, from a
generate_parameter_library spec (the spec's defaults) or from a live node (its
current values), and writes::

    {"$schema": "http://json-schema.org/draft-07/schema#", "title": ..., "type": "object",
     "definitions": {"<title>": {"type": "object", "properties": {...}, ...}},
     "properties": {"/**": {"type": "object",
                            "properties": {"ros__parameters": {"$ref": "#/definitions/<title>"}},
                            "required": ["ros__parameters"], "additionalProperties": false}},
     "required": ["/**"], "additionalProperties": false}

Dotted names nest as objects with ``additionalProperties: false``. Per parameter:
the type (an array's ``items`` type; a dynamically typed parameter has none),
``description`` (``read-only`` and the ``additional_constraints`` text are added to
it as notes), ``default``, the ranges and the validators JSON Schema can say:
``bounds``/``gt_eq``/``lower_bounds`` → ``minimum``, ``gt`` → ``exclusiveMinimum``
(and the upper ones), ``one_of`` → ``enum``, ``size_lt``/``size_gt``/``fixed_size``/
``not_empty`` → ``maxLength``/``minLength`` or ``maxItems``/``minItems``, ``unique`` →
``uniqueItems``, ``subset_of`` → ``items.enum``, element bounds → ``items`` bounds.
A range with a step, and a custom validator, are written as text in the description.
Non-finite numbers (JSON has none) are left out. Mapped parameters (``__map_<key>``)
become ``additionalProperties`` of their group.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable
from typing import Any

from ...core.descriptors import ParameterDescriptor, Validator
from ...core.values import INT64_MAX, INT64_MIN, ParameterType, ParameterValue
from .enforce import to_json
from .resolve import ENVELOPE, PARAMS_KEY

__all__ = ["derive_schema", "property_schema"]

T = ParameterType
_DBL_MAX = sys.float_info.max
_JSON_TYPES = {T.BOOL: "boolean", T.INTEGER: "integer", T.DOUBLE: "number", T.STRING: "string"}
_ITEMS: dict[ParameterType, dict[str, Any]] = {
    T.BOOL_ARRAY: {"type": "boolean"},
    T.INTEGER_ARRAY: {"type": "integer"},
    T.DOUBLE_ARRAY: {"type": "number"},
    T.STRING_ARRAY: {"type": "string"},
    T.BYTE_ARRAY: {"type": "integer", "minimum": 0, "maximum": 255},
}
_MAP = "__map_"


def _finite(x: object) -> bool:
    return not isinstance(x, float) or math.isfinite(x)


def _json_ok(x: Any) -> bool:
    if isinstance(x, list):
        return all(_finite(e) for e in x)
    return _finite(x)


def _tighten(target: dict[str, Any], key: str, value: object) -> None:
    """Set ``key`` to ``value`` or keep the tighter of the two (min* keeps the larger)."""
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        return
    if key not in target:
        target[key] = value
    elif key.startswith(("min", "exclusiveMin")):
        target[key] = max(target[key], value)
    else:
        target[key] = min(target[key], value)


def property_schema(value: ParameterValue | None, d: ParameterDescriptor) -> dict[str, Any]:
    """The schema of one parameter (rules in the module doc)."""
    out: dict[str, Any] = {}
    ptype = d.type
    notes: list[str] = []
    if not d.dynamic_typing and ptype in _JSON_TYPES:
        out["type"] = _JSON_TYPES[ptype]
    elif not d.dynamic_typing and ptype in _ITEMS:
        out["type"] = "array"
        out["items"] = dict(_ITEMS[ptype])
    scalar_target = out
    items: dict[str, Any] = out.get("items", {})
    numeric_target = items if ptype in (T.INTEGER_ARRAY, T.DOUBLE_ARRAY, T.BYTE_ARRAY) else out
    for r, is_int in ((d.integer_range, True), (d.floating_point_range, False)):
        if r is None or (is_int and ptype not in (T.INTEGER, T.INTEGER_ARRAY)):
            continue
        if not is_int and ptype not in (T.DOUBLE, T.DOUBLE_ARRAY):
            continue
        if r.step:
            notes.append(f"range [{r.from_value}, {r.to_value}] in steps of {r.step}")
            continue
        if r.from_value > r.to_value:
            notes.append(f"range [{r.from_value}, {r.to_value}]: only the two bounds")
            continue
        lo_open = r.from_value <= (INT64_MIN if is_int else -_DBL_MAX)
        hi_open = r.to_value >= (INT64_MAX if is_int else _DBL_MAX)
        if not lo_open:
            _tighten(numeric_target, "minimum", r.from_value)
        if not hi_open:
            _tighten(numeric_target, "maximum", r.to_value)
    for v in d.validators:
        if not _validator(v, ptype, scalar_target, items):
            notes.append(_text(v))
    if items and "items" in out:
        out["items"] = items
    description = d.description
    if d.read_only:
        notes.insert(0, "read-only")
    if d.additional_constraints:
        notes.append(d.additional_constraints)
    if notes:
        description = (description + " " if description else "") + "(" + "; ".join(notes) + ")"
    if description:
        out["description"] = description
    if value is not None and value.type is not T.NOT_SET:
        data = to_json(value)
        if _json_ok(data):
            out["default"] = data
    return out


def _text(v: Validator) -> str:
    return f"{v.kind}<>: [" + ", ".join(repr(a.value) for a in v.args) + "]"


def _validator(v: Validator, ptype: ParameterType, out: dict[str, Any], items: dict[str, Any]) -> bool:
    """Write ``v`` as keywords; False when JSON Schema cannot say it."""
    args = [to_json(a) for a in v.args]
    is_array = ptype.is_array
    sized = (
        (("minItems", "maxItems") if is_array else ("minLength", "maxLength"))
        if ptype is not T.NOT_SET
        else None
    )
    k = v.kind
    if k in ("bounds", "gt_eq", "lower_bounds", "lt_eq", "upper_bounds", "gt", "lt") and not is_array:
        if k == "bounds":
            _tighten(out, "minimum", args[0])
            _tighten(out, "maximum", args[1])
        else:
            key = {
                "gt_eq": "minimum",
                "lower_bounds": "minimum",
                "lt_eq": "maximum",
                "upper_bounds": "maximum",
                "gt": "exclusiveMinimum",
                "lt": "exclusiveMaximum",
            }[k]
            _tighten(out, key, args[0])
        return True
    if k == "one_of" and not is_array and isinstance(args[0], list):
        out["enum"] = args[0]
        return True
    if sized is not None and k in ("size_lt", "size_gt", "fixed_size", "not_empty"):
        lo, hi = sized
        if k == "size_lt":
            _tighten(out, hi, int(args[0]) - 1)
        elif k == "size_gt":
            _tighten(out, lo, int(args[0]) + 1)
        elif k == "fixed_size":
            _tighten(out, lo, int(args[0]))
            _tighten(out, hi, int(args[0]))
        else:
            _tighten(out, lo, 1)
        return True
    if k == "unique" and is_array:
        out["uniqueItems"] = True
        return True
    if k == "subset_of" and is_array and isinstance(args[0], list):
        items["enum"] = args[0]
        return True
    if k in ("element_bounds", "lower_element_bounds", "upper_element_bounds") and is_array:
        if k == "element_bounds":
            _tighten(items, "minimum", args[0])
            _tighten(items, "maximum", args[1])
        else:
            _tighten(items, "minimum" if k.startswith("lower") else "maximum", args[0])
        return True
    return False


def derive_schema(
    params: Iterable[tuple[str, ParameterValue | None, ParameterDescriptor]],
    *,
    title: str,
    node_key: str = ENVELOPE,
    required: Iterable[str] = (),
    extra_node_keys: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A draft-07 schema in Autoware's envelope for ``params`` (rules in the module doc).

    ``required`` names the parameters a file must give; ``extra_node_keys`` are more
    properties beside ``ros__parameters`` (a dump's ``paramdds__descriptors``)."""
    must = set(required)
    root: dict[str, Any] = {"type": "object", "properties": {}, "additionalProperties": False}
    for name, value, descriptor in params:
        parts = name.split(".")
        group = root
        for i, part in enumerate(parts[:-1]):
            if part.startswith(_MAP):
                extra = group.get("additionalProperties")
                if not isinstance(extra, dict):
                    extra = group["additionalProperties"] = _group()
                group = extra
                continue
            child = group["properties"].get(part)
            if child is not None and child.get("type") != "object":
                parts = [*parts[:i], ".".join(parts[i:])]  # both a value and a group: a dotted key
                break
            if child is None:
                child = group["properties"][part] = _group()
            if name in must and part not in group.setdefault("required", []):
                group["required"].append(part)
            group = child
        leaf = parts[-1]
        group["properties"][leaf] = property_schema(value, descriptor)
        if name in must:
            req = group.setdefault("required", [])
            if leaf not in req:
                req.append(leaf)
    node: dict[str, Any] = {
        "type": "object",
        "properties": {PARAMS_KEY: {"$ref": f"#/definitions/{_pointer_token(title)}"}},
        "required": [PARAMS_KEY],
        "additionalProperties": False,
    }
    node["properties"].update(extra_node_keys or {})
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": f"Parameters for {title}",
        "type": "object",
        "definitions": {title: root},
        "properties": {node_key: node},
        "required": [node_key],
        "additionalProperties": False,
    }


def _group() -> dict[str, Any]:
    return {"type": "object", "properties": {}, "additionalProperties": False}


def _pointer_token(text: str) -> str:
    return text.replace("~", "~0").replace("/", "~1")
