"""The native content filter's decisions on serialized samples (no DDS traffic).

The filter reads the key from CDR bytes: XCDR2 with a DHEADER (our ``@appendable``
types today), XCDR1 and plain XCDR2 (``@final``, the wire-interop change), in
either byte order. Whatever it cannot read it accepts (the handler checks again),
and it never crashes on garbage.
"""

import os
from dataclasses import dataclass

import pytest
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import appendable, final, key
from cyclonedds.idl.types import bounded_str, sequence, uint64
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.dds import filters
from paramdds.dds._binding import Endianness
from paramdds.dds.wire import types as wire

pytestmark = pytest.mark.skipif(
    not filters.NATIVE and not os.environ.get("PARAMDDS_REQUIRE_NATIVE"),
    reason="the native filter extension is not built (CI sets PARAMDDS_REQUIRE_NATIVE=1: fails there)",
)


@dataclass
@final
class FinalRequest(IdlStruct, typename="paramdds.GetParametersRequest"):
    """The request in the @final form (node_id, then client_id), serialized as XCDR1 and XCDR2."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    names: sequence[str] = ()  # type: ignore[assignment]


@dataclass
@appendable
class AppendableRequest(IdlStruct, typename="paramdds.GetParametersRequest"):
    """The request as the XCDR2 wire laid it out before the @final change: DHEADER first."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    names: sequence[str] = ()  # type: ignore[assignment]


def encodings(node: str, client_id: int = 7) -> list[bytes]:
    """One request in every encoding the filter reads (header byte 1: 0x00/01, 0x06/07, 0x08/09)."""
    out = []
    for endianness in (Endianness.Little, Endianness.Big):
        appendable_ = AppendableRequest(node_id=node, client_id=client_id, request_id=3, names=["x"])
        final_ = FinalRequest(node_id=node, client_id=client_id, request_id=3, names=["x"])
        out.append(appendable_.serialize(endianness=endianness))
        out.append(final_.serialize(endianness=endianness, use_version_2=False))
        out.append(final_.serialize(endianness=endianness, use_version_2=True))
    assert sorted(b[1] for b in out) == [0x00, 0x01, 0x06, 0x07, 0x08, 0x09]
    return out


def test_node_filter_keeps_hosted_nodes_in_both_forms_in_every_encoding() -> None:
    flt = filters.NativeFilter("nodes")
    flt.set_nodes(["robot/arm", "b"])
    for data in encodings("robot/arm") + encodings("/robot/arm") + encodings("/b"):
        assert flt.check(data)
    for data in encodings("c") + encodings("robot/ar") + encodings("robot/arm2") + encodings("//b"):
        assert not flt.check(data)
    assert flt.counts() == (18, 24, 0)


def test_node_filter_follows_updates_and_none_accepts_all() -> None:
    flt = filters.NativeFilter("nodes")
    (sample,) = encodings("late")[:1]
    assert not flt.check(sample)  # a fresh server hosts nothing
    flt.set_nodes(["late"])
    assert flt.check(sample)
    flt.set_nodes([])
    assert not flt.check(sample)
    flt.set_nodes(None)
    assert flt.check(sample)


def test_client_filter_reads_client_id_after_the_node_id_at_its_alignment() -> None:
    flt = filters.NativeFilter("client")
    flt.set_client_id(2**64 - 3)
    for node in ("a", "ab", "abc", "abcd", "n" * 255):  # every padding before the uint64
        assert all(flt.check(d) for d in encodings(node, client_id=2**64 - 3))
        assert not any(flt.check(d) for d in encodings(node, client_id=2**64 - 4))


def test_presence_filter_keeps_only_presence_of_the_watched_nodes() -> None:
    flt = filters.NativeFilter("presence")
    flt.set_nodes(None)

    def event(node: str, name: str) -> bytes:
        return wire.ParameterEvent(node_id=node, name=name, kind=wire.EVENT_PRESENCE).serialize()

    assert flt.check(event("a", "")) and flt.check(event("b", ""))
    assert not flt.check(event("a", "x"))
    flt.set_nodes(["a"])
    assert flt.check(event("a", "")) and flt.check(event("/a", ""))
    assert not flt.check(event("b", "")) and not flt.check(event("a", "x"))


@pytest.mark.parametrize(
    "data",
    [
        b"",
        b"\x00\x01",
        b"\x00\x01\x00\x00",  # header only
        b"\x00\x03\x00\x00" + b"\x05\x00\x00\x00abcd\x00",  # PL_CDR (mutable): not read
        b"\x01\x01\x00\x00" + b"\x02\x00\x00\x00a\x00",  # unknown representation
        b"\x00\x01\x00\x00" + b"\xff\xff\xff\x7fabc",  # length beyond the end
        b"\x00\x01\x00\x00" + b"\x03\x00\x00\x00abc",  # no terminating NUL
        b"\x00\x01\x00\x00" + b"\x00\x00\x00\x00",  # zero length
    ],
)
def test_what_the_filter_cannot_read_it_accepts(data: bytes) -> None:
    flt = filters.NativeFilter("nodes")  # hosts nothing: a readable sample would be rejected
    assert flt.check(data)
    assert flt.counts() == (0, 0, 1)


def test_client_filter_accepts_a_reply_cut_before_its_client_id() -> None:
    flt = filters.NativeFilter("client")
    flt.set_client_id(1)
    whole = wire.GetParametersResponse(node_id="abc", client_id=2).serialize()
    assert not flt.check(whole)  # positive control: the whole reply is read and refused
    assert flt.check(whole[:12])  # header, then "abc" with its length: the client id is missing


@settings(max_examples=200, deadline=None)
@given(
    hosted=st.sets(st.from_regex(r"[a-z][a-z0-9_]{0,12}", fullmatch=True), max_size=20),
    asked=st.from_regex(r"/?[a-z][a-z0-9_]{0,12}", fullmatch=True),
)
def test_node_decision_matches_the_handlers_rule(hosted: set[str], asked: str) -> None:
    flt = filters.NativeFilter("nodes")
    flt.set_nodes(hosted)
    expected = asked.removeprefix("/") in hosted
    assert all(flt.check(d) == expected for d in encodings(asked))


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=64))
def test_garbage_never_crashes(data: bytes) -> None:
    for kind in ("nodes", "client", "presence"):
        flt = filters.NativeFilter(kind)
        flt.check(b"\x00\x09\x00\x00" + data)
        flt.check(b"\x00\x01\x00\x00" + data)
        assert sum(flt.counts()) == 2


def test_status_names_the_filter() -> None:
    assert filters.status() == {"filter": "native"}


def test_origin_is_read_from_the_presence_tags() -> None:
    from paramdds.dds.filters import origin_of

    assert origin_of(["request_filter=native", "origin=ros2"]) == "ros2"
    assert origin_of(["request_filter=native"]) is None  # served here: no origin
    assert origin_of([]) is None
