"""The fast codec against cyclonedds-python's own: same bytes, same samples, never a crash.

The binding's interpreter is the oracle: for generated samples of every wire
type, both must write identical bytes and each must read the other's output.
Bytes that are not a valid sample must come back marked malformed, not raise,
because the binding decodes inside ``DataReader.take``.
"""

from dataclasses import dataclass, field
from typing import Any

import pytest
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import appendable
from cyclonedds.idl.types import bounded_str, int64, sequence, uint8, uint64
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.dds import types as wire
from paramdds.dds._binding import Endianness
from paramdds.dds.cdr import _codec, decode, encode, is_malformed

from .strategies import samples

WIRE_TYPES = [
    getattr(wire, name)
    for name in dir(wire)
    if isinstance(getattr(wire, name), type)
    and issubclass(getattr(wire, name), IdlStruct)
    and getattr(wire, name) is not IdlStruct
]


def _binding_bytes(sample: Any, endianness: Endianness = Endianness.Little) -> bytes:
    return bytes(type(sample).__idl__.serialize(sample, endianness=endianness))


def test_every_wire_type_is_covered() -> None:
    assert len(WIRE_TYPES) == 16 and wire.ParameterEvent in WIRE_TYPES


@pytest.mark.parametrize("cls", WIRE_TYPES, ids=lambda c: c.__name__)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_same_bytes_and_samples_as_the_binding(cls: type[IdlStruct], data: st.DataObject) -> None:
    sample = data.draw(samples(cls))
    ours = encode(sample)
    assert ours == _binding_bytes(sample)
    assert sample.serialize() == ours  # the installed method is ours
    assert decode(cls, ours) == sample
    assert _codec(cls).fast(ours, 4, len(ours))[0] == sample  # the fast path, not its fallback
    assert cls.__idl__.deserialize(ours) == sample
    assert cls.deserialize(ours) == sample


@settings(max_examples=40, deadline=None)
@given(samples(wire.ParameterEvent))
def test_big_endian_samples_go_to_the_binding(sample: wire.ParameterEvent) -> None:
    data = _binding_bytes(sample, Endianness.Big)
    assert data[:2] == b"\x00\x08"
    assert wire.ParameterEvent.deserialize(data) == sample


@settings(max_examples=300, deadline=None)
@given(
    sample=samples(wire.GetParametersResponse), cut=st.integers(0, 400), flips=st.lists(st.integers(0, 400))
)
def test_damaged_bytes_never_raise(sample: wire.GetParametersResponse, cut: int, flips: list[int]) -> None:
    data = bytearray(encode(sample))
    for i in flips:
        if 4 <= i < len(data):
            data[i] ^= 0xFF
    damaged = bytes(data[: max(4, len(data) - cut)])
    got = wire.GetParametersResponse.deserialize(damaged)
    assert isinstance(got, wire.GetParametersResponse)
    if is_malformed(got):
        assert got == wire.GetParametersResponse()  # defaults only: nothing half-read leaks out


def test_what_is_malformed() -> None:
    good = wire.GetParametersRequest(node_id="n1", names=["a", "é"]).serialize()
    bad_utf8 = good.replace("é".encode(), b"\xff\xfe")
    assert is_malformed(wire.GetParametersRequest.deserialize(bad_utf8))
    assert is_malformed(wire.GetParametersRequest.deserialize(good[:-3]))  # truncated
    no_nul = good[:-1] + b"x"
    assert is_malformed(wire.GetParametersRequest.deserialize(no_nul))
    assert not is_malformed(wire.GetParametersRequest.deserialize(good))
    assert is_malformed(wire.GetParametersRequest.deserialize(b""))  # the binding alone reads defaults
    assert is_malformed(wire.ParameterEvent.deserialize(_binding_bytes(_UnboundedKey("x" * 256))))
    assert not is_malformed(wire.ParameterEvent.deserialize(_binding_bytes(_UnboundedKey("x" * 255))))


def test_bounds_are_enforced_when_encoding() -> None:
    with pytest.raises(ValueError, match="bound of 255"):
        wire.ParameterEvent(node_id="x" * 256).serialize()
    with pytest.raises(ValueError, match="bound of 255"):
        wire.ParameterEvent(node_id="é" * 128).serialize()  # 256 bytes of UTF-8
    with pytest.raises(ValueError, match="bound of 1"):
        wire.ParameterEvent(descriptor=[wire.ParameterDescriptor()] * 2).serialize()


@dataclass
@appendable
class _UnboundedKey(IdlStruct, typename="test.UnboundedKey"):
    node_id: str = ""  # bounded_str[255] in ParameterEvent


# -- appendable evolution: an older writer (fewer members) and a newer one (more) -------------


@dataclass
@appendable
class _OldRequest(IdlStruct, typename="test.OldGetParametersRequest"):
    node_id: bounded_str[255] = ""
    client_id: uint64 = 0


@dataclass
@appendable
class _NewValue(IdlStruct, typename="test.NewParameterValue"):
    type: uint8 = 0
    bool_value: bool = False
    integer_value: int64 = 0
    double_value: float = 0.0
    string_value: str = ""
    byte_array_value: sequence[uint8] = field(default_factory=list)
    bool_array_value: sequence[bool] = field(default_factory=list)
    integer_array_value: sequence[int64] = field(default_factory=list)
    double_array_value: sequence[float] = field(default_factory=list)
    string_array_value: sequence[str] = field(default_factory=list)
    unit: str = ""  # a member added in a later release


def test_an_older_writers_missing_members_take_their_defaults() -> None:
    got = wire.GetParametersRequest.deserialize(_binding_bytes(_OldRequest("n1", 7)))
    assert not is_malformed(got)
    assert got == wire.GetParametersRequest(node_id="n1", client_id=7)


def test_a_newer_writers_extra_members_are_skipped() -> None:
    newer = _NewValue(type=4, string_value="s", string_array_value=["a"], unit="m/s")
    got = wire.ParameterValue.deserialize(_binding_bytes(newer))
    assert got == wire.ParameterValue(type=4, string_value="s", string_array_value=["a"])
