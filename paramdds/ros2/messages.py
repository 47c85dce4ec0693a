"""Conversions between rcl_interfaces messages and the core's values, descriptors and results.

ROS 2 messages hold arrays as ``array.array`` or lists, byte arrays as lists of one-byte
``bytes``; the core holds tuples and ``bytes``. ROS 2 set results carry a reason and no
code: :func:`code_of_reason` maps the reasons of rclcpp and rclpy to paramdds codes.
"""

from __future__ import annotations

import re
from typing import Any

from ..core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from ..core.results import SetResult
from ..core.values import NOT_SET, ParameterType, ParameterValue
from ..errors import ErrorCode

_T = ParameterType


def _bytes(items: Any) -> bytes:
    return b"".join(b if isinstance(b, bytes) else bytes([int(b)]) for b in items)


def value_from_ros(msg: Any) -> ParameterValue:
    """The core value of an ``rcl_interfaces/ParameterValue``."""
    t = _T(int(msg.type))
    if t is _T.NOT_SET:
        return NOT_SET
    raw: object
    if t is _T.BOOL:
        raw = bool(msg.bool_value)
    elif t is _T.INTEGER:
        raw = int(msg.integer_value)
    elif t is _T.DOUBLE:
        raw = float(msg.double_value)
    elif t is _T.STRING:
        raw = str(msg.string_value)
    elif t is _T.BYTE_ARRAY:
        raw = _bytes(msg.byte_array_value)
    elif t is _T.BOOL_ARRAY:
        raw = tuple(bool(x) for x in msg.bool_array_value)
    elif t is _T.INTEGER_ARRAY:
        raw = tuple(int(x) for x in msg.integer_array_value)
    elif t is _T.DOUBLE_ARRAY:
        raw = tuple(float(x) for x in msg.double_array_value)
    else:
        raw = tuple(str(x) for x in msg.string_array_value)
    return ParameterValue(t, raw)  # type: ignore[arg-type]


def value_to_ros(v: ParameterValue) -> Any:
    """The ``rcl_interfaces/ParameterValue`` of a core value."""
    from rcl_interfaces.msg import ParameterValue as Msg

    msg = Msg(type=int(v.type))
    t, x = v.type, v.value
    if t is _T.BOOL:
        msg.bool_value = bool(x)
    elif t is _T.INTEGER:
        msg.integer_value = int(x)  # type: ignore[arg-type]
    elif t is _T.DOUBLE:
        msg.double_value = float(x)  # type: ignore[arg-type]
    elif t is _T.STRING:
        msg.string_value = str(x)
    elif t is _T.BYTE_ARRAY:
        msg.byte_array_value = [bytes([b]) for b in x]  # type: ignore[union-attr,list-item]
    elif t is _T.BOOL_ARRAY:
        msg.bool_array_value = list(x)  # type: ignore[arg-type]
    elif t is _T.INTEGER_ARRAY:
        msg.integer_array_value = list(x)  # type: ignore[arg-type]
    elif t is _T.DOUBLE_ARRAY:
        msg.double_array_value = list(x)  # type: ignore[arg-type]
    elif t is _T.STRING_ARRAY:
        msg.string_array_value = list(x)  # type: ignore[arg-type]
    return msg


def parameter_to_ros(name: str, v: ParameterValue) -> Any:
    from rcl_interfaces.msg import Parameter as Msg

    return Msg(name=name, value=value_to_ros(v))


def descriptor_from_ros(msg: Any, name: str) -> ParameterDescriptor:
    """The core descriptor of an ``rcl_interfaces/ParameterDescriptor`` (every ROS 2 field)."""
    ir = msg.integer_range[0] if msg.integer_range else None
    fr = msg.floating_point_range[0] if msg.floating_point_range else None
    return ParameterDescriptor(
        name=msg.name or name,
        type=_T(int(msg.type)),
        description=str(msg.description),
        additional_constraints=str(msg.additional_constraints),
        read_only=bool(msg.read_only),
        dynamic_typing=bool(msg.dynamic_typing),
        integer_range=None
        if ir is None
        else IntegerRange(int(ir.from_value), int(ir.to_value), int(ir.step)),
        floating_point_range=(
            None
            if fr is None
            else FloatingPointRange(float(fr.from_value), float(fr.to_value), float(fr.step))
        ),
    )


def descriptor_to_ros(d: ParameterDescriptor) -> Any:
    """The ``rcl_interfaces/ParameterDescriptor`` of a core descriptor.

    ROS 2 has no validators: they are described in ``additional_constraints`` when that is
    empty, so a ROS 2 tool still shows them."""
    from rcl_interfaces.msg import FloatingPointRange as Fr
    from rcl_interfaces.msg import IntegerRange as Ir
    from rcl_interfaces.msg import ParameterDescriptor as Msg

    msg = Msg(
        name=d.name,
        type=int(d.type),
        description=d.description,
        additional_constraints=d.additional_constraints or _validators_text(d),
        read_only=d.read_only,
        dynamic_typing=d.dynamic_typing,
    )
    if d.integer_range is not None:
        r = d.integer_range
        msg.integer_range = [Ir(from_value=r.from_value, to_value=r.to_value, step=r.step)]
    if d.floating_point_range is not None:
        f = d.floating_point_range
        msg.floating_point_range = [Fr(from_value=f.from_value, to_value=f.to_value, step=f.step)]
    return msg


def _validators_text(d: ParameterDescriptor) -> str:
    parts = [f"{v.kind}({', '.join(repr(a.value) for a in v.args)})" for v in d.validators]
    return "; ".join(parts)


# rclcpp's and rclpy's reasons, lower-cased, first match wins
_REASONS: tuple[tuple[re.Pattern[str], ErrorCode], ...] = tuple(
    (re.compile(pattern), code)
    for pattern, code in (
        (r"read[- ]only", ErrorCode.READ_ONLY),
        (r"wrong parameter type|static parameter|statically typed|cannot undeclare", ErrorCode.TYPE_MISMATCH),
        (r"undeclared|not (been )?declared|not found", ErrorCode.NOT_FOUND),
        (r"out of range|valid step", ErrorCode.OUT_OF_RANGE),
    )
)


def code_of_reason(reason: str) -> ErrorCode:
    """The paramdds code of a refused ROS 2 set, from its reason (INVALID_VALUE by default:
    a node's own callback refused it)."""
    low = reason.lower()
    for pattern, code in _REASONS:
        if pattern.search(low):
            return code
    return ErrorCode.INVALID_VALUE


def result_from_ros(name: str, msg: Any) -> SetResult:
    """One parameter's result from an ``rcl_interfaces/SetParametersResult``."""
    reason = str(msg.reason)
    if msg.successful:
        return SetResult(name, True, reason)
    return SetResult(name, False, reason or "refused by the ROS 2 node", code_of_reason(reason))
