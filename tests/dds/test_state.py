"""The state decoder and encoder against the generated codec: same result, or both refuse.

``decode_state`` reads the common state sample in one pass and hands everything
else to ``decode_state_slowly`` (the generated codec and the wire→core
conversions). Whatever the bytes, the fast path may only return what the slow
one returns; it must actually be taken for the common shape; and bytes that are
no sample raise ``MalformedSample`` instead of reaching a monitor's table.
``encode_state`` must write exactly the generated encoder's bytes, or decline.
"""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.values import NOT_SET, ParameterType, ParameterValue
from paramdds.dds import types as wire
from paramdds.dds._binding import Endianness
from paramdds.dds.cdr import MalformedSample, encode
from paramdds.dds.convert import state_descriptor_to_wire, value_to_wire
from paramdds.dds.state import _decode_fast, decode_state, decode_state_slowly, encode_state

from .strategies import samples

_KEY = st.text(st.characters(exclude_categories=("Cs",)), min_size=0, max_size=40).filter(
    lambda s: len(s.encode()) <= 255
)
_SCALARS = st.one_of(
    st.booleans(),
    st.integers(-(2**63), 2**63 - 1),
    st.floats(allow_nan=False),
    st.text(st.characters(exclude_categories=("Cs",)), max_size=30),
)


@st.composite
def common_samples(draw: st.DrawFn) -> wire.ParameterEvent:
    """The shapes almost every state sample has: a scalar parameter with a plain
    descriptor, or a node's presence."""
    presence = draw(st.booleans())
    return wire.ParameterEvent(
        node_id=draw(_KEY),
        name="" if presence else draw(_KEY),
        kind=wire.EVENT_PRESENCE if presence else wire.EVENT_PARAMETER,
        revision=draw(st.integers(-(2**63), 2**63 - 1)),
        stamp=wire.Time(draw(st.integers(-(2**31), 2**31 - 1)), draw(st.integers(0, 999_999_999))),
        value=value_to_wire(NOT_SET if presence else ParameterValue.from_python(draw(_SCALARS))),
        host=draw(_KEY),
        pid=draw(st.integers(-(2**31), 2**31 - 1)),
        parameter_count=draw(st.integers(0, 2**32 - 1)),
    )


def _event(name: str, value: object) -> wire.ParameterEvent:
    return wire.ParameterEvent(node_id="n", name=name, value=value_to_wire(ParameterValue.from_python(value)))


def _same(data: bytes) -> None:
    """decode_state(data) returns what the slow path returns, or both refuse."""
    try:
        expected = decode_state_slowly(data)
    except MalformedSample:
        with pytest.raises(MalformedSample):
            decode_state(data)
        return
    assert decode_state(data) == expected


@settings(max_examples=300, deadline=None)
@given(common_samples())
def test_the_common_shapes_take_the_fast_path_and_agree(sample: wire.ParameterEvent) -> None:
    data = encode(sample)
    fast = _decode_fast(data)
    assert fast is not None
    assert fast == decode_state_slowly(data)
    ptype = ParameterType(sample.value.type)
    expected = None if ptype is ParameterType.NOT_SET else getattr(sample.value, f"{ptype.label}_value")
    assert (fast.node_id, fast.name, fast.kind, fast.value.value) == (
        sample.node_id,
        sample.name,
        sample.kind,
        expected,
    )
    assert (fast.host, fast.pid, fast.parameter_count) == (sample.host, sample.pid, sample.parameter_count)
    assert fast.descriptor == ParameterDescriptor(sample.name, ptype)


@settings(max_examples=200, deadline=None)
@given(samples(wire.ParameterEvent))
def test_any_sample_decodes_as_the_generated_codec_does(sample: wire.ParameterEvent) -> None:
    _same(encode(sample))


@settings(max_examples=400, deadline=None)
@given(
    sample=common_samples(),
    cut=st.integers(0, 160),
    flips=st.lists(st.tuples(st.integers(0, 200), st.integers(1, 255)), max_size=4),
)
def test_damaged_bytes_never_decode_differently(
    sample: wire.ParameterEvent, cut: int, flips: list[tuple[int, int]]
) -> None:
    data = bytearray(encode(sample))
    for i, mask in flips:
        if i < len(data):
            data[i] ^= mask
    _same(bytes(data[: max(0, len(data) - cut)]))


def test_other_shapes_take_the_slow_path_with_the_same_result() -> None:
    ranged = ParameterDescriptor("speed", ParameterType.DOUBLE, floating_point_range=FloatingPointRange(0, 5))
    with_range = _event("speed", 1.5)
    with_range.descriptor = state_descriptor_to_wire(ranged, ParameterValue.from_python(1.5))
    for what, sample in {"array": _event("a", [1.0, 2.0]), "descriptor": with_range}.items():
        data = encode(sample)
        assert _decode_fast(data) is None, what
        assert decode_state(data) == decode_state_slowly(data), what
    assert decode_state(encode(with_range)).descriptor == ranged
    assert decode_state(encode(_event("a", [1.0, 2.0]))).value == ParameterValue.from_python([1.0, 2.0])


def test_presence_and_a_parameter_without_value() -> None:
    presence = wire.ParameterEvent(
        node_id="n", kind=wire.EVENT_PRESENCE, revision=7, host="h", pid=42, parameter_count=3
    )
    got = decode_state(encode(presence))
    assert (got.kind, got.revision, got.host, got.pid, got.parameter_count, got.value) == (
        wire.EVENT_PRESENCE,
        7,
        "h",
        42,
        3,
        NOT_SET,
    )
    assert decode_state(encode(wire.ParameterEvent(node_id="n", name="gone"))).value is NOT_SET


def test_big_endian_and_special_doubles() -> None:
    for d in (math.inf, -math.inf, -0.0, 5e-324):
        sample = _event("d", d)
        got = decode_state(encode(sample))
        assert got.value.value == d and math.copysign(1, got.value.value) == math.copysign(1, d)
        big = bytes(wire.ParameterEvent.__idl__.serialize(sample, endianness=Endianness.Big))
        assert decode_state(big) == got  # another encoding: the binding reads it, same result
    assert math.isnan(decode_state(encode(_event("d", math.nan))).value.value)  # type: ignore[arg-type]


def test_what_is_refused() -> None:
    good = encode(_event("p", 1))
    # header, "n", "p" (each length + text + padding), kind + padding to 8 after the header,
    # revision, Time {sec, nanosec}: the value's type byte is at offset 36
    unknown_type = bytearray(good)
    assert unknown_type[36] == ParameterType.INTEGER
    unknown_type[36] = 42
    for bad in (good[:-4], good[:20], b"", bytes(unknown_type), good.replace(b"p\x00", b"\xff\x00")):
        with pytest.raises(MalformedSample):
            decode_state(bad)


@settings(max_examples=300, deadline=None)
@given(sample=common_samples(), description=st.sampled_from(["", "m/s"]))
def test_a_servers_state_sample_is_encoded_as_the_generated_encoder_does(
    sample: wire.ParameterEvent, description: str
) -> None:
    value = decode_state_slowly(encode(sample)).value
    descriptor = ParameterDescriptor(sample.name, value.type, description=description)
    wire_sample = wire.ParameterEvent(
        node_id=sample.node_id,
        name=sample.name,
        revision=sample.revision,
        stamp=sample.stamp,
        value=value_to_wire(value),
        descriptor=state_descriptor_to_wire(descriptor, value),
    )
    args = (sample.node_id, sample.name, sample.revision, sample.stamp.sec, sample.stamp.nanosec, value)
    got = encode_state(*args, descriptor)
    if value is NOT_SET or description:  # not the common shape: the caller builds the wire sample
        assert got is None
        return
    expected = encode(wire_sample)
    assert got == expected + bytes(-len(expected) % 4)  # padded as DataWriter.write pads
    assert decode_state(got).value == value


def test_what_the_state_encoder_leaves_to_the_generated_one() -> None:
    plain = ParameterDescriptor("a", ParameterType.DOUBLE_ARRAY)
    array = ParameterValue.from_python([1.0])
    assert encode_state("n", "a", 1, 0, 0, array, plain) is None
    long = "x" * 256
    one = ParameterValue.from_python(1)
    assert encode_state(long, "a", 1, 0, 0, one, ParameterDescriptor("a", ParameterType.INTEGER)) is None
    assert encode_state("n", "a", 2**63, 0, 0, one, ParameterDescriptor("a", ParameterType.INTEGER)) is None
