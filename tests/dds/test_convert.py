"""Core <-> wire conversions, round-tripped through Cyclone's CDR (XCDR2) encoder."""

from __future__ import annotations

import math
from typing import TypeVar

import pytest
from cyclonedds.idl import IdlStruct
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from paramdds.core.values import INT64_MAX, INT64_MIN, NOT_SET, Parameter, ParameterType, ParameterValue
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.convert import (
    descriptor_from_wire,
    descriptor_to_wire,
    parameter_from_wire,
    parameter_to_wire,
    value_from_wire,
    value_to_wire,
)
from paramdds.errors import InvalidValueError

W = TypeVar("W", bound=IdlStruct)

# CDR strings are NUL-terminated and UTF-8: no NUL, no lone surrogates.
texts = st.text(st.characters(blacklist_characters="\x00", blacklist_categories=("Cs",)), max_size=40)
int64s = st.integers(INT64_MIN, INT64_MAX) | st.sampled_from([INT64_MIN, INT64_MAX, 0, -1])
doubles = st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from(
    [math.nan, math.inf, -math.inf, -0.0, 5e-324]
)

values = st.one_of(
    st.just(NOT_SET),
    st.builds(ParameterValue, st.just(ParameterType.BOOL), st.booleans()),
    st.builds(ParameterValue, st.just(ParameterType.INTEGER), int64s),
    st.builds(ParameterValue, st.just(ParameterType.DOUBLE), doubles),
    st.builds(ParameterValue, st.just(ParameterType.STRING), texts),
    st.builds(ParameterValue, st.just(ParameterType.BYTE_ARRAY), st.binary(max_size=64)),
    st.builds(ParameterValue, st.just(ParameterType.BOOL_ARRAY), st.lists(st.booleans()).map(tuple)),
    st.builds(ParameterValue, st.just(ParameterType.INTEGER_ARRAY), st.lists(int64s).map(tuple)),
    st.builds(ParameterValue, st.just(ParameterType.DOUBLE_ARRAY), st.lists(doubles).map(tuple)),
    st.builds(ParameterValue, st.just(ParameterType.STRING_ARRAY), st.lists(texts, max_size=8).map(tuple)),
)

finite = st.floats(allow_nan=False)
descriptors = st.builds(
    ParameterDescriptor,
    name=texts,
    type=st.sampled_from(list(ParameterType)),
    description=texts,
    additional_constraints=texts,
    read_only=st.booleans(),
    dynamic_typing=st.booleans(),
    integer_range=st.none() | st.builds(IntegerRange, int64s, int64s, st.integers(0, 2**64 - 1)),
    floating_point_range=st.none() | st.builds(FloatingPointRange, finite, finite, finite),
    validators=st.lists(
        st.builds(
            Validator, st.sampled_from(["bounds", "one_of", "not_empty", "x"]), st.lists(values).map(tuple)
        ),
        max_size=4,
    ).map(tuple),
)


def through_cdr(sample: W) -> W:
    """Serialize with Cyclone's encoder and decode again, as a remote reader would."""
    return type(sample).deserialize(sample.serialize())


def same_descriptor(a: ParameterDescriptor, b: ParameterDescriptor) -> bool:
    plain = ("name", "type", "description", "additional_constraints", "read_only", "dynamic_typing")
    return (
        all(getattr(a, f) == getattr(b, f) for f in plain)
        and a.integer_range == b.integer_range
        and a.floating_point_range == b.floating_point_range
        and len(a.validators) == len(b.validators)
        and all(
            x.kind == y.kind
            and len(x.args) == len(y.args)
            and all(p.same_as(q) for p, q in zip(x.args, y.args, strict=True))
            for x, y in zip(a.validators, b.validators, strict=True)
        )
    )


@settings(deadline=None)  # shared CI machines: time is not what these test
@given(values)
def test_value_round_trip(v: ParameterValue) -> None:
    back = value_from_wire(through_cdr(value_to_wire(v)))
    assert back.same_as(v)
    assert type(back.value) is type(v.value)
    if v.type.is_array and v.type is not ParameterType.BYTE_ARRAY:
        assert isinstance(back.value, tuple)


@settings(deadline=None)  # shared CI machines: time is not what these test
@given(texts, values)
def test_parameter_round_trip(name: str, v: ParameterValue) -> None:
    back = parameter_from_wire(through_cdr(parameter_to_wire(Parameter(name, v))))
    assert back.name == name
    assert back.value.same_as(v)


@settings(deadline=None)  # shared CI machines: time is not what these test
@given(descriptors)
def test_descriptor_round_trip(d: ParameterDescriptor) -> None:
    back = descriptor_from_wire(through_cdr(descriptor_to_wire(d)))
    assert same_descriptor(back, d)
    assert isinstance(back.validators, tuple)


@pytest.mark.parametrize(
    ("ptype", "value", "member"),
    [
        (ParameterType.BOOL, True, "bool_value"),
        (ParameterType.INTEGER, INT64_MIN, "integer_value"),
        (ParameterType.DOUBLE, -math.inf, "double_value"),
        (ParameterType.STRING, "ünïcødé ✓", "string_value"),
        (ParameterType.BYTE_ARRAY, b"\x00\xff", "byte_array_value"),
        (ParameterType.BOOL_ARRAY, (True, False), "bool_array_value"),
        (ParameterType.INTEGER_ARRAY, (INT64_MAX, INT64_MIN), "integer_array_value"),
        (ParameterType.DOUBLE_ARRAY, (1.5, math.inf), "double_array_value"),
        (ParameterType.STRING_ARRAY, ("a", ""), "string_array_value"),
    ],
)
def test_wire_layout(ptype: ParameterType, value: object, member: str) -> None:
    """One type byte (the rcl_interfaces number) and exactly one member set."""
    w = value_to_wire(ParameterValue.of(ptype, value))
    assert w.type == int(ptype)
    expected = list(value) if isinstance(value, (tuple, bytes)) else value
    assert getattr(w, member) == expected
    defaults = wire.ParameterValue()
    others = [f for f in vars(defaults) if f not in ("type", member)]
    assert all(getattr(w, f) == getattr(defaults, f) for f in others)


def test_bytes_come_back_as_bytes() -> None:
    assert value_from_wire(wire.ParameterValue(type=5, byte_array_value=[0, 255])).value == b"\x00\xff"


def test_not_set_is_the_shared_constant() -> None:
    assert value_from_wire(wire.ParameterValue()) is NOT_SET


def test_absent_ranges_are_empty_sequences() -> None:
    w = descriptor_to_wire(ParameterDescriptor("x", ParameterType.INTEGER))
    assert w.integer_range == [] and w.floating_point_range == [] and w.validators == []
    assert descriptor_from_wire(w).integer_range is None


@pytest.mark.parametrize("byte", [10, 99, 255])
def test_unknown_type_byte_is_refused(byte: int) -> None:
    with pytest.raises(InvalidValueError, match=str(byte)):
        value_from_wire(wire.ParameterValue(type=byte))
    with pytest.raises(InvalidValueError, match=str(byte)):
        descriptor_from_wire(wire.ParameterDescriptor(name="x", type=byte))
    with pytest.raises(InvalidValueError):
        parameter_from_wire(wire.Parameter(name="x", value=wire.ParameterValue(type=byte)))


def test_state_descriptor_is_left_out_only_when_it_is_name_and_type() -> None:
    from paramdds.core.descriptors import IntegerRange, ParameterDescriptor
    from paramdds.core.values import ParameterType, ParameterValue
    from paramdds.dds.wire.convert import state_descriptor_from_wire, state_descriptor_to_wire

    value = ParameterValue.of(ParameterType.INTEGER, 3)
    plain = ParameterDescriptor("a.b", ParameterType.INTEGER)
    assert state_descriptor_to_wire(plain, value) == []
    assert state_descriptor_from_wire([], "a.b", value) == plain
    ranged = ParameterDescriptor("a.b", ParameterType.INTEGER, integer_range=IntegerRange(0, 10, 1))
    dynamic = ParameterDescriptor("a.b", ParameterType.INTEGER, dynamic_typing=True)
    for rich in (ranged, dynamic):
        sent = state_descriptor_to_wire(rich, value)
        assert len(sent) == 1
        assert state_descriptor_from_wire(sent, "a.b", value) == rich
