"""Retried requests: the same (client_id, request_id) is applied once and answered the same.

A client that timed out resends its request unchanged (that is what a retry on
the wire looks like). The server must not apply it twice nor publish a second
change, and must answer with the reply it gave the first time, for a bounded
window of recent requests.
"""

from __future__ import annotations

import itertools
import time

import pytest

import paramdds.dds.server as server_module
from paramdds.core.results import SetVeto
from paramdds.core.table import ParameterTable
from paramdds.core.values import ParameterValue
from paramdds.dds.wire import types as wire

from .conftest import DDS
from .rawwire import RawPeer, same_reply

NODE = "dedup"
_ids = itertools.count(1)


def _table(node: str = NODE) -> ParameterTable:
    table = ParameterTable(node)
    table.declare("count", 0)
    table.declare("label", "x")
    return table


def _set(node: str, client_id: int, request_id: int, **values: object) -> wire.SetParametersRequest:
    params = []
    for name, v in values.items():
        if isinstance(v, int):
            params.append(wire.Parameter(name, wire.ParameterValue(type=2, integer_value=v)))
        else:
            params.append(wire.Parameter(name, wire.ParameterValue(type=4, string_value=str(v))))
    return wire.SetParametersRequest(
        node_id=node, client_id=client_id, request_id=request_id, parameters=params
    )


def _changes_of(peer: RawPeer, name: str, value: int) -> int:
    return sum(
        1
        for e in peer.pump_events()
        if e.name == name and e.kind == wire.EVENT_PARAMETER and e.value.integer_value == value
    )


@pytest.mark.timeout(30)
def test_resent_request_is_applied_once_published_once_and_answered_the_same(
    domain_id: int, dds: DDS
) -> None:
    table = _table()
    commits: list[object] = []
    table.add_change_listener(commits.append)
    dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id), count_events=True)
    start = table.revision

    request = _set(NODE, 0xC0FFEE, 1, count=5)
    first = peer.call(request)
    assert first.results[0].successful and first.revision == start + 1
    for _ in range(3):  # three retries of the very same sample
        peer.send(request)
    replies = peer.replies(request, count=4)
    assert len(replies) == 4
    assert all(same_reply(first, r) for r in replies)

    time.sleep(0.2)  # let any duplicate state sample arrive
    assert table.revision == start + 1
    assert len(commits) == 1
    assert _changes_of(peer, "count", 5) == 1, "a retried set published a second change"


@pytest.mark.timeout(30)
def test_retry_while_the_first_attempt_is_still_running(domain_id: int, dds: DDS) -> None:
    """The realistic case: the server is slow, the client times out and resends at once."""
    table = _table()
    table.add_on_set_callback(lambda params: (time.sleep(0.4), SetVeto(True))[1])
    dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id), count_events=True)
    start = table.revision

    request = _set(NODE, 77, 9, count=11)
    peer.send(request)
    assert peer.replies(request, timeout=0.1) == []  # "timed out"
    peer.send(request)  # the retry, while the first is still in its callback
    replies = peer.replies(request, count=2, timeout=5)
    assert len(replies) == 2 and same_reply(replies[0], replies[1])
    time.sleep(0.2)
    assert table.revision == start + 1
    assert _changes_of(peer, "count", 11) == 1


@pytest.mark.timeout(30)
def test_late_retry_does_not_undo_a_newer_change(domain_id: int, dds: DDS) -> None:
    table = _table()
    dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id))
    old = _set(NODE, 1, 1, count=5)
    assert peer.call(old).results[0].successful
    assert peer.call(_set(NODE, 2, 1, count=7)).results[0].successful  # another client, same request id
    peer.send(old)  # client 1's late duplicate
    assert len(peer.replies(old, count=2)) == 2
    assert table.get("count") == ParameterValue.from_python(7)


@pytest.mark.timeout(30)
def test_failed_request_retried_gets_the_same_failure(domain_id: int, dds: DDS) -> None:
    table = _table()
    dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id))
    start = table.revision
    bad = _set(NODE, 3, 1, count="not an integer")
    first = peer.call(bad)
    assert not first.results[0].successful and first.results[0].code == "TYPE_MISMATCH"
    peer.send(bad)
    replies = peer.replies(bad, count=2)
    assert len(replies) == 2 and same_reply(replies[0], replies[1])
    assert table.revision == start


@pytest.mark.timeout(30)
def test_same_ids_for_another_node_are_another_request(domain_id: int, dds: DDS) -> None:
    a, b = _table("node_a"), _table("node_b")
    dds.server(domain_id, a, b)
    peer = RawPeer(dds.participant(domain_id))
    assert peer.call(_set("node_a", 5, 1, count=1)).results[0].successful
    assert peer.call(_set("node_b", 5, 1, count=2)).results[0].successful
    assert a.get("count").value == 1 and b.get("count").value == 2


@pytest.mark.timeout(30)
def test_dedup_window_is_bounded(domain_id: int, dds: DDS, monkeypatch: pytest.MonkeyPatch) -> None:
    """The window holds DEDUP_WINDOW replies; older ones are forgotten (memory stays bounded)."""
    monkeypatch.setattr(server_module, "DEDUP_WINDOW", 8)
    table = _table()
    server = dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id))
    oldest = _set(NODE, 9, 1, count=100)
    peer.call(oldest)
    for i in range(2, 22):
        peer.call(_set(NODE, 9, i, label=f"l{i}"))
    assert len(server._replies) == 8
    revision = table.revision
    peer.send(oldest)  # out of the window: a new request as far as the server knows
    assert len(peer.replies(oldest, count=2)) == 2
    assert table.revision == revision + 1


@pytest.mark.timeout(30)
def test_dedup_window_is_bounded_by_bytes_too(
    domain_id: int, dds: DDS, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A few big requests cannot hold unbounded memory: the window also stops at DEDUP_BYTES."""
    monkeypatch.setattr(server_module, "DEDUP_BYTES", 4096)
    table = _table()
    server = dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id))
    small = _set(NODE, 5, 1, count=1)
    peer.call(small)
    revision = table.revision
    peer.send(small)  # positive control: still in the window, answered from it
    assert len(peer.replies(small, count=2)) == 2 and table.revision == revision
    for i in range(2, 5):
        peer.call(_set(NODE, 5, i, label="x" * 1500))  # 3 x ~1.5 kB: over 4 kB in all
    assert server._replies_bytes <= 4096 and len(server._replies) < 4
    peer.send(small)  # pushed out by bytes, not by count: applied again
    assert len(peer.replies(small, count=3)) == 3
    assert table.revision == revision + 4
