"""Odd but type-valid samples from a foreign writer: answered with errors or ignored, never a crash.

Each sample below is something the paramdds client would never send (it checks
first) but a plain cyclonedds program can. After every one the server must still
answer, its table must only have changed where the request was valid, and
nothing may be logged as an internal error; a kind of malformation may be logged
at most once however often it arrives.
"""

from __future__ import annotations

import itertools
import logging
from collections import Counter
from typing import Any

import pytest
from cyclonedds.pub import DataWriter

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.limits import MAX_PARAMETERS_PER_REQUEST
from paramdds.core.table import ParameterTable
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.dds._binding import write_serialized
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.convert import value_to_wire

from .conftest import DDS, wait
from .rawwire import RawPeer

NODE = "odd"
CLIENT = 0x5EED
_ids = itertools.count(1)


def _table() -> ParameterTable:
    table = ParameterTable(NODE)
    table.declare("i", 1)
    table.declare("d", 1.5)
    table.declare("s", "text")
    table.declare("dyn", 1, ParameterDescriptor("dyn", dynamic_typing=True))
    table.declare("group.a", True)
    table.declare("group.sub.b", [1, 2])
    return table


def _p(name: str, **members: Any) -> wire.Parameter:
    return wire.Parameter(name, wire.ParameterValue(**members))


def _set(*params: wire.Parameter, node: str = NODE, **fields: Any) -> wire.SetParametersRequest:
    return wire.SetParametersRequest(
        node_id=node, client_id=CLIENT, request_id=next(_ids), parameters=list(params), **fields
    )


def _get(*names: str, node: str = NODE) -> wire.GetParametersRequest:
    return wire.GetParametersRequest(node_id=node, client_id=CLIENT, request_id=next(_ids), names=list(names))


def _list(depth: int, *prefixes: str) -> wire.ListParametersRequest:
    return wire.ListParametersRequest(
        node_id=NODE, client_id=CLIENT, request_id=next(_ids), depth=depth, prefixes=list(prefixes)
    )


@pytest.fixture
def harness(domain_id: int, dds: DDS, caplog: pytest.LogCaptureFixture) -> tuple[ParameterTable, RawPeer]:
    caplog.set_level(logging.DEBUG, logger="paramdds")
    table = _table()
    dds.server(domain_id, table)
    return table, RawPeer(dds.participant(domain_id))


def _still_answers(peer: RawPeer) -> None:
    reply = peer.call(_get("i"))
    assert reply.code == "" and reply.results[0].code == ""


def _no_internal_errors(caplog: pytest.LogCaptureFixture) -> None:
    bad = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert not bad, [r.getMessage() for r in bad]
    repeats = Counter(r.getMessage() for r in caplog.records if r.name.startswith("paramdds"))
    assert all(n <= 1 for n in repeats.values()), f"logged more than once: {repeats}"


@pytest.mark.timeout(30)
def test_unknown_type_byte(harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture) -> None:
    table, peer = harness
    start = table.revision
    for _ in range(2):  # twice: the second must not be logged again
        plain = peer.call(_set(_p("i", type=200, integer_value=9), _p("s", type=4, string_value="ok")))
        assert [(r.successful, r.code) for r in plain.results] == [(False, "INVALID_VALUE"), (True, "")]
        assert "200" in plain.results[0].reason
        atomic = peer.call(_set(_p("s", type=4, string_value="no"), _p("i", type=255), atomic=True))
        assert not any(r.successful for r in atomic.results)
        assert atomic.results[1].code == "INVALID_VALUE"
    assert table.get("i").value == 1 and table.get("s").value == "ok"
    assert table.revision == start + 2  # one per valid parameter set (an equal value is a change too)
    _still_answers(peer)
    _no_internal_errors(caplog)


@pytest.mark.timeout(30)
def test_values_in_the_wrong_member(
    harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture
) -> None:
    """The type byte decides which member counts (as in rcl_interfaces); the others are ignored."""
    table, peer = harness
    reply = peer.call(
        _set(
            _p("i", type=2, integer_value=7, double_value=3.5, string_value="junk"),
            _p("d", type=3, double_value=2.25, integer_array_value=[1, 2, 3]),
        )
    )
    assert all(r.successful for r in reply.results)
    assert table.get("i") == ParameterValue(ParameterType.INTEGER, 7)
    assert table.get("d") == ParameterValue(ParameterType.DOUBLE, 2.25)
    # the member of another type than the type byte: a type error, not a silent conversion
    wrong = peer.call(_set(_p("i", type=3, integer_value=8)))
    assert not wrong.results[0].successful and wrong.results[0].code == "TYPE_MISMATCH"
    _still_answers(peer)
    _no_internal_errors(caplog)


@pytest.mark.timeout(30)
def test_odd_revisions_depths_and_sizes(
    harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture
) -> None:
    table, peer = harness
    # any negative expected_revision means "no compare-and-set"
    assert peer.call(_set(_p("i", type=2, integer_value=3), expected_revision=-5)).results[0].successful
    huge = peer.call(_set(_p("i", type=2, integer_value=4), expected_revision=2**63 - 1))
    assert huge.results[0].code == "CONFLICT" and table.get("i").value == 3

    # a depth no client would send (a negative one read as unsigned): every level
    listed = peer.call(_list(2**64 - 1))
    assert listed.code == "" and "group.sub.b" in listed.names
    assert peer.call(_list(0, "", ".", "..", "group.")).code == ""

    # over the request limits: one error for the request, nothing applied
    many = [_p(f"n{i}", type=1) for i in range(MAX_PARAMETERS_PER_REQUEST + 1)]
    assert peer.call(_set(*many), timeout=20).code == "TOO_LARGE"
    assert peer.call(_get(*(["i"] * (MAX_PARAMETERS_PER_REQUEST + 1))), timeout=20).code == "TOO_LARGE"

    # names no client would send get a status each
    names = ["", "\x00", "a" * 10_000, "..", "i"]
    reply = peer.call(_get(*names))
    assert [r.code for r in reply.results][-1] == ""
    assert all(r.code in ("INVALID_NAME", "NOT_FOUND") for r in reply.results[:-1])

    # deleting a statically typed parameter, a set of nothing
    assert peer.call(_set(_p("i", type=0))).results[0].code == "TYPE_MISMATCH"
    empty = peer.call(_set())
    assert empty.code == "" and empty.results == []
    assert table.get("i").value == 3
    _still_answers(peer)
    _no_internal_errors(caplog)


@pytest.mark.timeout(30)
def test_requests_for_nodes_not_hosted_are_ignored(
    harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture
) -> None:
    table, peer = harness
    start = table.revision
    for node in ("", "/", "not_here", "odd/", "ODD", "o\x00dd", "ö" * 100):
        request = _set(_p("i", type=2, integer_value=99), node=node)
        peer.send(request)
        peer.send(_get("i", node=node))
        assert peer.replies(request, timeout=0.05) == []
    # the leading-slash form is the same node (canonical ids)
    assert peer.call(_get("i", node="/odd")).results[0].code == ""
    assert table.revision == start and table.get("i").value == 1
    _still_answers(peer)
    _no_internal_errors(caplog)


@pytest.mark.timeout(30)
def test_retained_flag_on_the_interactive_path_is_ignored(
    harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture
) -> None:
    """An assignment must come from the retained (TRANSIENT_LOCAL) writer, never a VOLATILE one."""
    table, peer = harness
    request = _set(_p("i", type=2, integer_value=42), retained=True)
    peer.send(request)
    assert peer.replies(request, timeout=0.3) == []
    assert table.get("i").value == 1
    _still_answers(peer)
    _no_internal_errors(caplog)


@pytest.mark.timeout(60)
def test_a_burst_of_every_kind_leaves_the_server_serving(
    harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture
) -> None:
    table, peer = harness
    samples: list[Any] = []
    for k in range(30):
        samples += [
            _set(_p("i", type=200 + k % 50)),
            _set(_p("dyn", type=k % 10, integer_value=k, string_value="s", bool_array_value=[True])),
            _set(_p("d", type=3, double_value=float("nan")), _p("s", type=9), atomic=bool(k % 2)),
            _get("", "x" * 300, "\n"),
            _list(2**63 + k, "\x7f"),
        ]
    for s in samples:
        peer.send(s)
    for s in samples:
        assert peer.replies(s, timeout=5), f"no answer to {s}"
    _still_answers(peer)
    # what is left is well formed: every entry typed, its descriptor agreeing
    for name, value, descriptor in table.snapshot():
        assert value.type is not ParameterType.NOT_SET, name
        assert descriptor.dynamic_typing or descriptor.type is value.type, name
    _no_internal_errors(caplog)


@pytest.mark.timeout(30)
def test_undecodable_samples_are_dropped_and_later_ones_served(
    harness: tuple[ParameterTable, RawPeer], caplog: pytest.LogCaptureFixture
) -> None:
    # bytes no encoder would write: invalid UTF-8 in the key and in a nested string.
    # cyclonedds-python decodes inside take(): this used to kill the server's dispatch thread.
    table, peer = harness
    good = _get("i", "s").serialize()
    for _ in range(3):
        peer.send_bytes("GetParametersRequest", good.replace(NODE.encode(), b"\xffdd"))
        peer.send_bytes("GetParametersRequest", good.replace(b"s\x00", b"\xff\x00"))
        peer.send_bytes(
            "SetParametersRequest",
            _set(_p("s", type=4, string_value="xyz")).serialize().replace(b"xyz", b"\xc3(z"),
        )
    _still_answers(peer)
    assert table.get("s").value == "text"

    def dropped() -> set[str]:
        return {r.getMessage().split(":")[0] for r in caplog.records if "undecodable" in r.getMessage()}

    # the set reader is drained after the get reader, so its warning may follow the answer
    expected = {"GetParametersRequest", "SetParametersRequest"}
    assert wait(lambda: dropped() == expected, 3.0), dropped()
    _no_internal_errors(caplog)


@pytest.mark.timeout(30)
def test_a_monitor_drops_broken_state_samples_alone(
    domain_id: int, dds: DDS, caplog: pytest.LogCaptureFixture
) -> None:
    # A foreign writer on ParameterEvents: bytes that are no sample, and a value with an
    # unknown type byte, among good samples. Each broken one is dropped by itself (an
    # exception used to lose the rest of its batch); nothing else is lost or logged twice.
    caplog.set_level(logging.DEBUG, logger="paramdds")
    participant = dds.participant(domain_id)
    writer = DataWriter(
        participant,
        make_topic(participant, "ParameterEvents", wire.ParameterEvent),
        QosProfiles.load().writer("ParameterEvents"),
    )
    monitor = dds.monitor(domain_id)

    def state(name: str, value: object) -> wire.ParameterEvent:
        return wire.ParameterEvent(
            node_id="foreign", name=name, revision=1, value=value_to_wire(ParameterValue.from_python(value))
        )

    presence = wire.ParameterEvent(node_id="foreign", kind=wire.EVENT_PRESENCE, revision=1, parameter_count=3)
    unknown_type = state("unknown", 1)
    unknown_type.value.type = 42
    for _ in range(3):
        writer.write(state("a", 1.5))
        bad_utf8 = state("bad.utf8", "x").serialize().replace(b"bad.utf8", b"bad.\xff\xfe\xfd\xfc")
        write_serialized(writer, bad_utf8)
        writer.write(unknown_type)
        writer.write(state("b", "text"))
        writer.write(state("c", [1, 2]))
    writer.write(presence)

    assert monitor.wait_complete(["foreign"], timeout=5.0)
    values = {name: v.value for name, (v, _d) in monitor.snapshot()["foreign"].parameters.items()}
    assert values == {"a": 1.5, "b": "text", "c": (1, 2)}
    dropped = [r for r in caplog.records if "undecodable" in r.getMessage()]
    assert [r.getMessage().split(":")[0] for r in dropped] == ["ParameterEvents"]
    _no_internal_errors(caplog)
