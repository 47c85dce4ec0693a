"""Values and descriptors as JSON and back: the one mapping every JSON user of paramdds shares.

A parameter value or descriptor becomes JSON in three forms, all produced and read here
(pure functions: no DDS, no I/O, no JSON text; the caller dumps and loads):

* **bare**, what a person reads (the CLI's ``-o json``, the web console's API; docs/cli.md and
  docs/web.md): a value is its plain JSON, ``2.0``, ``"auto"``, ``[1, 2]``; byte arrays are
  lists of ints; a double that is not finite is the string ``"nan"``, ``"inf"`` or
  ``"-inf"`` (JSON has no such numbers); not_set is ``null``. A descriptor is
  ``{"type", "description", "read_only", "dynamic_typing", "integer_range",
  "floating_point_range", "additional_constraints", "validators"}``, a range
  ``{"from_value", "to_value", "step"}`` or ``null``, a validator ``{"kind", "args": [values]}``.
  A bare value carries no type: read it back with its type (:func:`value_of_json`).
* **tagged**, what a program reads without knowing the parameter (the Zenoh payloads,
  docs/zenoh.md): a value is ``{"type": "double", "value": <bare>}`` and a descriptor is the
  bare one with its keys in the wire's order (``additional_constraints`` third) and tagged
  validator arguments (``json_descriptor(d, tagged=True)``). Lossless both ways
  (:func:`value_of_tagged`, :func:`descriptor_of_json`); a double may come back as a JSON
  integer (``2``: JSON writers in other languages drop the ``.0``).
* **rows**, the journal's positional on-disk form (``server --persist``): a value is
  ``[type number, data]`` and a descriptor an eight-element list; doubles stay floats (the
  journal's JSON writes ``NaN`` and ``Infinity``), so a row is compact and exact.

The key order of each dict is part of the form: the Zenoh payload bytes and the CLI's
output are pinned by tests.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..errors import ParamddsError
from .descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from .values import ParameterType, ParameterValue

_NON_FINITE = ("nan", "inf", "-inf")

# -- bare and tagged: values ---------------------------------------------------------------


def json_scalar(v: object) -> object:
    """One scalar in its JSON shape (a double that is not finite becomes a string)."""
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def json_value(value: ParameterValue | None) -> object:
    """A value in the bare form (``None`` and not_set are ``null``)."""
    if value is None:
        return None
    v = value.value
    if isinstance(v, bytes):
        return list(v)
    if isinstance(v, tuple):
        return [json_scalar(x) for x in v]
    return json_scalar(v)


def json_tagged_value(value: ParameterValue) -> dict[str, object]:
    """A value in the tagged form: ``{"type": label, "value": bare}``."""
    return {"type": value.type.label, "value": json_value(value)}


def _double_of(v: object) -> object:
    if isinstance(v, str) and v in _NON_FINITE:
        return float(v)
    if isinstance(v, int) and not isinstance(v, bool):
        return float(v)  # JSON writers in other languages may drop the ".0"
    return v


def value_of_json(ptype: ParameterType, raw: object) -> ParameterValue:
    """The value of type ``ptype`` whose bare form is ``raw`` (checked: TYPE_MISMATCH if it is not one)."""
    if ptype is ParameterType.DOUBLE:
        raw = _double_of(raw)
    elif ptype is ParameterType.DOUBLE_ARRAY and isinstance(raw, list):
        raw = [_double_of(x) for x in raw]
    return ParameterValue.of(ptype, raw)


def value_of_tagged(obj: object) -> ParameterValue:
    """The value of a tagged form ``{"type", "value"}``."""
    if not isinstance(obj, Mapping) or "type" not in obj:
        raise ParamddsError(f"not a value object (want {{'type', 'value'}}): {str(obj)[:80]}")
    return value_of_json(ParameterType.from_label(str(obj["type"])), obj.get("value"))


# -- bare and tagged: descriptors -----------------------------------------------------------


def _range_json(r: IntegerRange | FloatingPointRange | None) -> object:
    if r is None:
        return None
    return {
        "from_value": json_scalar(r.from_value),
        "to_value": json_scalar(r.to_value),
        "step": json_scalar(r.step),
    }


def json_descriptor(d: ParameterDescriptor, *, tagged: bool = False) -> dict[str, object]:
    """A descriptor in the bare form, or with ``tagged`` in the tagged one (Zenoh's key order,
    validator arguments as tagged values)."""
    arg = json_tagged_value if tagged else json_value
    out: dict[str, object] = {"type": d.type.label, "description": d.description}
    if tagged:
        out["additional_constraints"] = d.additional_constraints
    out["read_only"] = d.read_only
    out["dynamic_typing"] = d.dynamic_typing
    out["integer_range"] = _range_json(d.integer_range)
    out["floating_point_range"] = _range_json(d.floating_point_range)
    if not tagged:
        out["additional_constraints"] = d.additional_constraints
    out["validators"] = [{"kind": v.kind, "args": [arg(a) for a in v.args]} for v in d.validators]
    return out


def _double_field(v: object) -> float:
    return float(str(_double_of(v)))


def descriptor_of_json(name: str, obj: object) -> ParameterDescriptor:
    """The descriptor of ``name`` from its tagged form (absent fields take their defaults)."""
    if not isinstance(obj, Mapping):
        raise ParamddsError(f"not a descriptor object for {name!r}")
    ir, fr = obj.get("integer_range"), obj.get("floating_point_range")
    return ParameterDescriptor(
        name,
        ParameterType.from_label(str(obj.get("type", "not_set"))),
        description=str(obj.get("description", "")),
        additional_constraints=str(obj.get("additional_constraints", "")),
        read_only=bool(obj.get("read_only", False)),
        dynamic_typing=bool(obj.get("dynamic_typing", False)),
        integer_range=None
        if not isinstance(ir, Mapping)
        else IntegerRange(int(ir["from_value"]), int(ir["to_value"]), int(ir.get("step", 0))),
        floating_point_range=None
        if not isinstance(fr, Mapping)
        else FloatingPointRange(
            _double_field(fr["from_value"]), _double_field(fr["to_value"]), _double_field(fr.get("step", 0.0))
        ),
        validators=tuple(
            Validator(str(v["kind"]), tuple(value_of_tagged(a) for a in v.get("args", ())))
            for v in obj.get("validators", ())
        ),
    )


# -- rows: the journal's positional form ----------------------------------------------------


def value_row(v: ParameterValue) -> list[object]:
    """A value as ``[type number, data]`` (byte arrays as lists of ints, doubles as floats)."""
    data = v.value
    return [int(v.type), list(data) if isinstance(data, bytes) else data]


def value_of_row(item: Any) -> ParameterValue:
    """The value of a row ``[type number, data]``."""
    t, data = item
    return ParameterValue.of(ParameterType(t), data)


def descriptor_row(d: ParameterDescriptor) -> list[object]:
    """A descriptor as ``[type number, description, additional_constraints, read_only,
    dynamic_typing, integer range | null, floating-point range | null, [[kind, [value rows]]]]``,
    a range being ``[from_value, to_value, step]``."""
    ir, fr = d.integer_range, d.floating_point_range
    return [
        int(d.type),
        d.description,
        d.additional_constraints,
        d.read_only,
        d.dynamic_typing,
        None if ir is None else [ir.from_value, ir.to_value, ir.step],
        None if fr is None else [fr.from_value, fr.to_value, fr.step],
        [[v.kind, [value_row(a) for a in v.args]] for v in d.validators],
    ]


def descriptor_of_row(name: str, item: Any) -> ParameterDescriptor:
    """The descriptor of ``name`` from its row."""
    t, description, constraints, read_only, dynamic, ir, fr, validators = item
    return ParameterDescriptor(
        name,
        ParameterType(t),
        description=description,
        additional_constraints=constraints,
        read_only=read_only,
        dynamic_typing=dynamic,
        integer_range=None if ir is None else IntegerRange(*ir),
        floating_point_range=None if fr is None else FloatingPointRange(*fr),
        validators=tuple(Validator(k, tuple(value_of_row(a) for a in args)) for k, args in validators),
    )
