"""What the CLI prints: the JSON shapes and their table and YAML renderings.

JSON shapes (pinned by tests and documented in docs/cli.md, whose examples the tests run):

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
import sys
from collections.abc import Mapping
from typing import Any

from ..core.descriptors import ParameterDescriptor
from ..core.values import ParameterType, ParameterValue


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


def dumps_yaml(obj: object) -> str:
    import yaml

    return str(yaml.safe_dump(obj, sort_keys=False, allow_unicode=True, default_flow_style=None))


def typed(value: ParameterValue | None) -> str:
    """``double 1.5`` — a value with its type, as the demo and table outputs print it."""
    if value is None or value.type is ParameterType.NOT_SET:
        return "not_set"
    return f"{value.type.label} {value.show()}"


def emit(output: str, data: object, table: str | None = None) -> None:
    """Print ``data`` as JSON or YAML, or ``table`` (pre-rendered text) for the table format."""
    if output == "json":
        text = dumps_json(data)
    elif output == "yaml":
        text = dumps_yaml(data).rstrip("\n")
    else:
        text = table if table is not None else dumps_yaml(data).rstrip("\n")
    if text:
        sys.stdout.write(text + "\n")
    sys.stdout.flush()


def describe_table(descriptors: Mapping[str, Mapping[str, Any]]) -> str:
    """Descriptors as indented ``key: value`` blocks, skipping empty fields."""
    lines: list[str] = []
    for name, d in descriptors.items():
        lines.append(f"{name}:")
        for key, value in d.items():
            if value in (None, "", [], False) and key not in ("type", "read_only"):
                continue
            lines.append(f"  {key}: {dumps_json(value, pretty=False)}")
    return "\n".join(lines)


def results_table(results: Mapping[str, Mapping[str, object]], revision: int) -> str:
    """Set/delete results: ``name: ok`` or ``name: FAILED: reason``, then the revision."""
    lines = []
    for name, r in results.items():
        reason = str(r["reason"])
        if r["successful"]:
            lines.append(f"{name}: ok" + (f" ({reason})" if reason else ""))
        else:
            lines.append(f"{name}: FAILED: {reason}")
    lines.append(f"revision: {revision}")
    return "\n".join(lines)
