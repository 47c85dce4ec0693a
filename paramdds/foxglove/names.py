"""Foxglove parameter names and values: ``/<node>.<param>`` and JSON values with type hints.

Pure functions (no I/O, no JSON text). A parameter is named as foxglove_bridge names a
ROS 2 node's: ``/`` + node id + ``.`` + parameter name, split at the first dot (node ids
have no dots; over Zenoh the node id is ``site/node``, so ``/site/node.param``).

A value is ``{"value": ..., "type": hint}`` with the hint only where JSON alone would lose
the type: ``float64`` on a double (a JavaScript client reads ``1.0`` as ``1``),
``float64_array`` on a double array, ``byte_array`` on a byte array (base64 text). Booleans,
integers, strings and their arrays carry no hint. A double that is not finite is the string
``"nan"``, ``"inf"`` or ``"-inf"`` with the ``float64`` hint (JSON has no such numbers), as
everywhere else paramdds writes JSON. A not_set value has no ``value`` key (the protocol's
"unset").
"""

from __future__ import annotations

import base64
import binascii
import math
from collections.abc import Mapping

from ..core.jsonform import json_scalar, json_value, value_of_json
from ..core.values import NOT_SET, ParameterType, ParameterValue
from ..errors import ParamddsError

FLOAT64 = "float64"
FLOAT64_ARRAY = "float64_array"
BYTE_ARRAY = "byte_array"
HINTS = (FLOAT64, FLOAT64_ARRAY, BYTE_ARRAY)

_HINT_OF = {
    ParameterType.DOUBLE: FLOAT64,
    ParameterType.DOUBLE_ARRAY: FLOAT64_ARRAY,
    ParameterType.BYTE_ARRAY: BYTE_ARRAY,
}
_TYPE_OF_HINT = {hint: ptype for ptype, hint in _HINT_OF.items()}
_PLAIN = frozenset({ParameterType.BOOL, ParameterType.INTEGER, ParameterType.STRING})


class BadValue(ParamddsError):
    """A Foxglove value paramdds cannot take (a nested object, a mixed list, bad base64...)."""


def foxglove_name(node: str, name: str) -> str:
    """``/<node>.<name>``."""
    return f"/{node}.{name}"


def split_name(full: str) -> tuple[str, str] | None:
    """``/<node>.<param>`` → (node, param), split at the first dot; None when not of that shape."""
    if not full.startswith("/"):
        return None
    node, dot, name = full[1:].partition(".")
    if not dot or not node or not name:
        return None
    return node, name


def to_foxglove(name: str, value: ParameterValue | None) -> dict[str, object]:
    """One entry of a ``parameterValues`` message: ``{"name", "value", "type"?}``; no ``value``
    when ``value`` is None or not_set (unset: an offline node's, a deleted parameter's)."""
    if value is None:
        return {"name": name}
    ptype, v = value.type, value.value
    if ptype in _PLAIN:  # the common cases first: a get of every node makes 200,000 of these
        return {"name": name, "value": v}
    if ptype is ParameterType.DOUBLE:
        return {"name": name, "value": v if math.isfinite(v) else json_scalar(v), "type": FLOAT64}  # type: ignore[arg-type]
    out: dict[str, object] = {"name": name}
    if ptype is ParameterType.NOT_SET:
        return out
    if value.type is ParameterType.BYTE_ARRAY:
        assert isinstance(value.value, bytes)
        out["value"] = base64.b64encode(value.value).decode("ascii")
    else:
        out["value"] = json_value(value)
    hint = _HINT_OF.get(value.type)
    if hint is not None:
        out["type"] = hint
    return out


def from_foxglove(entry: Mapping[str, object], current: ParameterType | None = None) -> ParameterValue:
    """The value of a ``setParameters`` entry (``{"name", "value"?, "type"?}``); not_set when it has
    no ``value`` (or ``null``). ``current``: the parameter's type on its node, if known, which
    decides what a hint leaves open (an integer given for a double, an empty list's element
    type). BadValue with a one-line reason for what is no parameter value."""
    raw = entry.get("value")
    if raw is None:
        return NOT_SET
    hint = entry.get("type")
    if hint is not None and hint not in _TYPE_OF_HINT:
        raise BadValue(f"unknown type hint {str(hint)[:40]!r} (known: {', '.join(HINTS)})")
    try:
        if hint is not None:
            return _of_hint(_TYPE_OF_HINT[str(hint)], raw)
        return _inferred(raw, current)
    except BadValue:
        raise
    except ParamddsError as exc:
        raise BadValue(exc.message) from exc


def _of_hint(ptype: ParameterType, raw: object) -> ParameterValue:
    if ptype is ParameterType.BYTE_ARRAY and not isinstance(raw, str):
        raise BadValue("a byte_array value is base64 text")
    return _as_type(ptype, raw)


def _as_type(ptype: ParameterType, raw: object) -> ParameterValue:
    """``raw`` as a value of ``ptype`` (a byte array: base64 text or a list of ints)."""
    if ptype is ParameterType.BYTE_ARRAY and isinstance(raw, str):
        try:
            return ParameterValue.of(ptype, base64.b64decode(raw, validate=True))
        except binascii.Error as exc:
            raise BadValue(f"a byte_array value is base64 text: {exc}") from exc
    if ptype in (ParameterType.DOUBLE, ParameterType.DOUBLE_ARRAY):
        items = raw if isinstance(raw, list) else [raw]
        if any(isinstance(x, bool) for x in items):
            raise BadValue(f"a {ptype.label} value has no booleans")
    return value_of_json(ptype, raw)


def _inferred(raw: object, current: ParameterType | None) -> ParameterValue:
    if isinstance(raw, dict):
        raise BadValue("a nested object is no paramdds parameter value")
    if current is not None and current is not ParameterType.NOT_SET:
        try:
            return _as_type(current, raw)
        except ParamddsError:
            pass  # not of the node's type: taken as it is, for the node to judge the change of type
    if isinstance(raw, list) and not raw:
        raise BadValue("an empty list has no type of its own: give the parameter's type hint")
    if (
        isinstance(raw, list)
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in raw)
        and any(isinstance(x, float) for x in raw)
    ):
        return value_of_json(ParameterType.DOUBLE_ARRAY, raw)  # [1, 1.5]: a JavaScript double array
    return ParameterValue.from_python(raw)
