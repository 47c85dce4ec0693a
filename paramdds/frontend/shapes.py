"""The JSON shapes of values and descriptors, as the CLI prints them and the console serves them.

Pinned by tests and documented in docs/cli.md and docs/web.md (whose examples the tests run):

* a value: bool, int, float (a double always has a ``.`` or an exponent: ``2.0``),
  string, arrays as lists, byte arrays as lists of ints, non-finite doubles as the
  strings ``"nan"``, ``"inf"``, ``"-inf"``; not_set is ``null``;
* a descriptor: ``{"type", "description", "read_only", "dynamic_typing",
  "integer_range", "floating_point_range", "additional_constraints",
  "validators"}``, a range being ``{"from_value", "to_value", "step"}`` or ``null``
  and a validator ``{"kind", "args": [values]}``.

Pure functions; no DDS here.
"""

from __future__ import annotations

import json
import math

from ..core.descriptors import ParameterDescriptor
from ..core.values import ParameterType, ParameterValue


def shown_node(node: str, origin: str | None) -> str:
    """A node id as an operator knows it: a ROS 2 node (mirrored by the bridge, origin
    ``ros2``) with its leading slash (``/arm/driver``), a paramdds node without
    (``robot1``). Both forms are accepted wherever a node is given."""
    return "/" + node if origin == "ros2" else node


def json_scalar(v: object) -> object:
    """One scalar in its JSON shape (non-finite doubles become strings)."""
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def json_value(value: ParameterValue | None) -> object:
    """A parameter value in its JSON shape."""
    if value is None or value.type is ParameterType.NOT_SET:
        return None
    v = value.value
    if isinstance(v, bytes):
        return list(v)
    if isinstance(v, tuple):
        return [json_scalar(x) for x in v]
    return json_scalar(v)


def json_descriptor(d: ParameterDescriptor) -> dict[str, object]:
    """A descriptor in its JSON shape."""
    ir, fr = d.integer_range, d.floating_point_range
    return {
        "type": d.type.label,
        "description": d.description,
        "read_only": d.read_only,
        "dynamic_typing": d.dynamic_typing,
        "integer_range": None
        if ir is None
        else {"from_value": ir.from_value, "to_value": ir.to_value, "step": ir.step},
        "floating_point_range": None
        if fr is None
        else {
            "from_value": json_scalar(fr.from_value),
            "to_value": json_scalar(fr.to_value),
            "step": json_scalar(fr.step),
        },
        "additional_constraints": d.additional_constraints,
        "validators": [{"kind": v.kind, "args": [json_value(a) for a in v.args]} for v in d.validators],
    }


def dumps_json(obj: object, *, pretty: bool = True) -> str:
    """JSON text; refuses NaN (values must go through :func:`json_value` first)."""
    return json.dumps(obj, indent=2 if pretty else None, ensure_ascii=False, allow_nan=False)
