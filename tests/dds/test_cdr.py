"""The fast codec against cyclonedds-python's own: same bytes, same samples, never a crash.

The binding's interpreter is the oracle: for generated samples of every wire
type, both must write identical bytes and each must read the other's output.
Bytes that are not a valid sample must come back marked malformed, not raise,
because the binding decodes inside ``DataReader.take``.
"""

from dataclasses import dataclass
from typing import Any

import pytest
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.dds._binding import Endianness
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.cdr import _codec, decode, encode, is_malformed

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
    assert len(WIRE_TYPES) == 19 and wire.ParameterEvent in WIRE_TYPES


@pytest.mark.parametrize("cls", WIRE_TYPES, ids=lambda c: c.__name__)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_same_bytes_and_samples_as_the_binding(cls: type[IdlStruct], data: st.DataObject) -> None:
    sample = data.draw(samples(cls))
    ours = encode(sample)
    assert ours == _binding_bytes(sample)
    assert sample.serialize() == ours  # the installed method is ours
    assert decode(cls, ours) == sample
    assert _codec(cls).decode(ours, 4, len(ours)) == (sample, len(ours))  # every byte read, none left
    assert cls.__idl__.deserialize(ours) == sample
    assert cls.deserialize(ours) == sample


@settings(max_examples=40, deadline=None)
@given(samples(wire.ParameterEvent))
def test_big_endian_samples_go_to_the_binding(sample: wire.ParameterEvent) -> None:
    data = _binding_bytes(sample, Endianness.Big)
    assert data[:2] == b"\x00\x00"  # CDR_BE
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
    at_bound = wire.ParameterEvent(node_id="x" * 255).serialize()
    assert not is_malformed(wire.ParameterEvent.deserialize(at_bound))
    # the same sample with a key past the bound, as a writer that ignores it would send it
    # (263 bytes and a NUL keep the members after it at the same offsets modulo 8)
    assert at_bound[4:8] == (256).to_bytes(4, "little")
    over = at_bound[:4] + (264).to_bytes(4, "little") + b"x" * 263 + at_bound[263:]
    assert _UnboundedKey.deserialize(over[: 8 + 264]) == _UnboundedKey("x" * 263)
    assert is_malformed(wire.ParameterEvent.deserialize(over))


def test_bounds_are_enforced_when_encoding() -> None:
    with pytest.raises(ValueError, match="bound of 255"):
        wire.ParameterEvent(node_id="x" * 256).serialize()
    with pytest.raises(ValueError, match="bound of 255"):
        wire.ParameterEvent(node_id="é" * 128).serialize()  # 256 bytes of UTF-8
    with pytest.raises(ValueError, match="bound of 1"):
        wire.ParameterEvent(descriptor=[wire.ParameterDescriptor()] * 2).serialize()


@dataclass
@final
class _UnboundedKey(IdlStruct, typename="test.UnboundedKey"):
    node_id: str = ""  # bounded_str[255] in ParameterEvent


# -- the wire every vendor reads: plain XCDR1, and what else we accept ---------------------------


def test_samples_are_plain_xcdr1_little_endian() -> None:
    data = wire.GetParametersRequest(node_id="n1", client_id=7, names=["a"]).serialize()
    # header CDR_LE; then the key's length (3 with the NUL), "n1\0", one byte of padding, and
    # client_id at offset 8 after the header (8-byte alignment, no DHEADER anywhere)
    assert data[:4] == b"\x00\x01\x00\x00"
    assert data[4:12] == b"\x03\x00\x00\x00n1\x00\x00"
    assert data[12:20] == (7).to_bytes(8, "little")


def test_trailing_padding_is_ignored() -> None:
    """Cyclone C pads a sample to a multiple of 4 and notes it in the header's option bits."""
    sample = wire.ListParametersRequest(node_id="n1", prefixes=["ab"])
    data = sample.serialize()
    padded = data[:3] + bytes([-len(data) & 3]) + data[4:] + bytes(-len(data) & 3)
    assert len(padded) % 4 == 0 and padded != data
    assert wire.ListParametersRequest.deserialize(padded) == sample


@settings(max_examples=30, deadline=None)
@given(samples(wire.SetParametersRequest))
def test_xcdr2_from_a_peer_that_prefers_it_is_read_by_the_binding(sample: wire.SetParametersRequest) -> None:
    data = bytes(wire.SetParametersRequest.__idl__.serialize(sample, use_version_2=True))
    assert data[:2] == b"\x00\x07"  # PLAIN_CDR2 little-endian: a final type's XCDR2
    got = wire.SetParametersRequest.deserialize(data)
    assert not is_malformed(got) and got == sample
