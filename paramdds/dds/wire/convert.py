"""Conversions between the core's value classes and the wire types (hot path).

The wire follows rcl_interfaces: a ``type`` byte and one member per type, all
others left at their defaults. The core holds one Python value per parameter
(arrays as tuples, byte arrays as ``bytes``). Both directions are table driven
and do no validation beyond what the wire cannot guarantee: an unknown type
byte from a peer raises :class:`~paramdds.errors.InvalidValueError`. Values
coming from the wire are built without re-checking (a CDR ``int64`` always
fits, a ``sequence<boolean>`` always holds bools).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from ...core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from ...core.values import NOT_SET, ParameterType, ParameterValue
from ...core.values import Parameter as CoreParameter
from ...errors import InvalidValueError
from . import types as wire

__all__ = [
    "descriptor_from_wire",
    "descriptor_to_wire",
    "is_plain",
    "parameter_from_wire",
    "parameter_to_wire",
    "value_from_wire",
    "value_to_wire",
]

_T = ParameterType
_TYPES: tuple[ParameterType, ...] = tuple(ParameterType)  # index == type byte

_NOT_SET = NOT_SET

_TO_WIRE: dict[ParameterType, Callable[[object], wire.ParameterValue]] = {
    _T.NOT_SET: lambda v: wire.ParameterValue(type=0),
    _T.BOOL: lambda v: wire.ParameterValue(type=1, bool_value=v),  # type: ignore[arg-type]
    _T.INTEGER: lambda v: wire.ParameterValue(type=2, integer_value=v),  # type: ignore[arg-type]
    _T.DOUBLE: lambda v: wire.ParameterValue(type=3, double_value=v),  # type: ignore[arg-type]
    _T.STRING: lambda v: wire.ParameterValue(type=4, string_value=v),  # type: ignore[arg-type]
    _T.BYTE_ARRAY: lambda v: wire.ParameterValue(type=5, byte_array_value=list(v)),  # type: ignore[call-overload]
    _T.BOOL_ARRAY: lambda v: wire.ParameterValue(type=6, bool_array_value=list(v)),  # type: ignore[call-overload]
    _T.INTEGER_ARRAY: lambda v: wire.ParameterValue(type=7, integer_array_value=list(v)),  # type: ignore[call-overload]
    _T.DOUBLE_ARRAY: lambda v: wire.ParameterValue(type=8, double_array_value=list(v)),  # type: ignore[call-overload]
    _T.STRING_ARRAY: lambda v: wire.ParameterValue(type=9, string_array_value=list(v)),  # type: ignore[call-overload]
}

_FROM_WIRE: tuple[Callable[[wire.ParameterValue], ParameterValue], ...] = (
    lambda w: _NOT_SET,
    lambda w: ParameterValue(_T.BOOL, bool(w.bool_value)),
    lambda w: ParameterValue(_T.INTEGER, w.integer_value),
    lambda w: ParameterValue(_T.DOUBLE, w.double_value),
    lambda w: ParameterValue(_T.STRING, w.string_value),
    lambda w: ParameterValue(_T.BYTE_ARRAY, bytes(w.byte_array_value)),
    lambda w: ParameterValue(_T.BOOL_ARRAY, tuple(w.bool_array_value)),
    lambda w: ParameterValue(_T.INTEGER_ARRAY, tuple(w.integer_array_value)),
    lambda w: ParameterValue(_T.DOUBLE_ARRAY, tuple(w.double_array_value)),
    lambda w: ParameterValue(_T.STRING_ARRAY, tuple(w.string_array_value)),
)


def value_to_wire(v: ParameterValue) -> wire.ParameterValue:
    """The wire form of a core value."""
    return _TO_WIRE[v.type](v.value)


def value_from_wire(w: wire.ParameterValue) -> ParameterValue:
    """The core value of a wire value; ``InvalidValueError`` for an unknown type byte."""
    t = w.type
    if not 0 <= t < len(_FROM_WIRE):
        raise InvalidValueError(f"unknown parameter type {t} on the wire")
    return _FROM_WIRE[t](w)


def _type_from_wire(t: int) -> ParameterType:
    if not 0 <= t < len(_TYPES):
        raise InvalidValueError(f"unknown parameter type {t} on the wire")
    return _TYPES[t]


def descriptor_to_wire(d: ParameterDescriptor) -> wire.ParameterDescriptor:
    """The wire form of a descriptor; an absent range is an empty sequence."""
    ir, fr = d.integer_range, d.floating_point_range
    return wire.ParameterDescriptor(
        name=d.name,
        type=int(d.type),
        description=d.description,
        additional_constraints=d.additional_constraints,
        read_only=d.read_only,
        dynamic_typing=d.dynamic_typing,
        integer_range=[] if ir is None else [wire.IntegerRange(ir.from_value, ir.to_value, ir.step)],
        floating_point_range=(
            [] if fr is None else [wire.FloatingPointRange(fr.from_value, fr.to_value, fr.step)]
        ),
        validators=[
            wire.Validator(kind=v.kind, args=[value_to_wire(a) for a in v.args]) for v in d.validators
        ],
    )


def descriptor_from_wire(w: wire.ParameterDescriptor) -> ParameterDescriptor:
    """The core descriptor of a wire descriptor; ``InvalidValueError`` for an unknown type byte."""
    ir = w.integer_range[0] if w.integer_range else None
    fr = w.floating_point_range[0] if w.floating_point_range else None
    return ParameterDescriptor(
        name=w.name,
        type=_type_from_wire(w.type),
        description=w.description,
        additional_constraints=w.additional_constraints,
        read_only=bool(w.read_only),
        dynamic_typing=bool(w.dynamic_typing),
        integer_range=None if ir is None else IntegerRange(ir.from_value, ir.to_value, ir.step),
        floating_point_range=None if fr is None else FloatingPointRange(fr.from_value, fr.to_value, fr.step),
        validators=tuple(Validator(v.kind, tuple(value_from_wire(a) for a in v.args)) for v in w.validators),
    )


def parameter_to_wire(p: CoreParameter) -> wire.Parameter:
    """The wire form of a name and value."""
    return wire.Parameter(name=p.name, value=_TO_WIRE[p.value.type](p.value.value))


def parameter_from_wire(w: wire.Parameter) -> CoreParameter:
    """The core form of a wire name and value."""
    return CoreParameter(w.name, value_from_wire(w.value))


def state_descriptor_to_wire(d: ParameterDescriptor, value: ParameterValue) -> list[wire.ParameterDescriptor]:
    """A state sample's descriptor: empty when it is only the name and the value's type.

    Most parameters carry no description, range or validator; leaving their
    descriptor out cuts the Python encode and decode cost of a state sample by
    about a third. :func:`state_descriptor_from_wire` restores it exactly.
    """
    return [] if is_plain(d, value) else [descriptor_to_wire(d)]


def is_plain(d: ParameterDescriptor, value: ParameterValue) -> bool:
    """Whether ``d`` says nothing but the parameter's name and the type of ``value``."""
    return d == ParameterDescriptor(d.name, value.type)


def state_descriptor_from_wire(
    seq: Sequence[wire.ParameterDescriptor], name: str, value: ParameterValue
) -> ParameterDescriptor:
    return descriptor_from_wire(seq[0]) if seq else ParameterDescriptor(name, value.type)
