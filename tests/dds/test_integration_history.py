"""Blame and history over real DDS: who changed what, when, through what; refusals kept; paging."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.history import Outcome, Retention
from paramdds.core.table import ParameterTable
from paramdds.core.values import ParameterValue
from paramdds.dds.server import ParameterServer
from paramdds.errors import ErrorCode

from .helpers import DdsSession

pytestmark = pytest.mark.timeout(60)

NODE = "robot"


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def _table() -> ParameterTable:
    t = ParameterTable(NODE)
    speed = ParameterDescriptor("speed", floating_point_range=FloatingPointRange(0.0, 2.0, 0.0))
    t.declare("speed", 1.0, speed)
    t.declare("mode", "auto")
    return t


def test_history_lists_each_change_with_its_author_old_and_new_values(dds: DdsSession) -> None:
    dds.server(_table())
    alice, bob = dds.client(as_="alice"), dds.client(as_="bob")
    alice.set(NODE, {"speed": 1.5})
    bob.set(NODE, {"speed": 1.7, "mode": "manual"})
    refused = bob.set(NODE, {"speed": 9.0})
    assert not refused.results[0].successful

    reply = alice.history(NODE)
    rows = [(r.name, r.who, r.via, r.old, r.new, r.applied) for r in reply.records]
    fv = sv = ParameterValue.from_python
    me = rows[0][1]
    assert rows[:2] == [
        ("mode", me, "start", None, sv("auto"), True),
        ("speed", me, "start", None, fv(1.0), True),
    ]
    assert rows[2:] == [
        ("speed", "alice", "api", fv(1.0), fv(1.5), True),
        ("speed", "bob", "api", fv(1.5), fv(1.7), True),
        ("mode", "bob", "api", sv("auto"), sv("manual"), True),
        ("speed", "bob", "api", fv(1.7), fv(9.0), False),
    ]
    assert reply.records[-1].code == ErrorCode.OUT_OF_RANGE.value and "2.0" in reply.records[-1].reason
    assert not any(r.verified for r in reply.records[2:])  # claims, in plain mode
    assert reply.records[3].revision == reply.records[4].revision  # one change, one revision
    assert [r.seq for r in reply.records] == sorted(r.seq for r in reply.records)
    assert not reply.compacted

    only_refused = alice.history(NODE, outcome=Outcome.REFUSED)
    assert [(r.name, r.who) for r in only_refused.records] == [("speed", "bob")]
    by_alice = alice.history(NODE, ["speed"], who="al*")
    assert [r.new for r in by_alice.records] == [fv(1.5)]
    since = alice.history(NODE, since_revision=reply.records[2].revision)
    assert [r.who for r in since.records] == ["bob", "bob", "bob"]


def test_a_late_get_with_descriptors_carries_each_parameters_last_change(dds: DdsSession) -> None:
    dds.server(_table())
    before = time.time()
    dds.client(as_="carol").set(NODE, {"mode": "manual"})
    reply = dds.client().get(NODE, ["mode", "speed"], with_descriptors=True)
    mode, speed = reply.results
    assert mode.last_change is not None and speed.last_change is not None
    assert (mode.last_change.who, mode.last_change.via, mode.last_change.verified) == ("carol", "api", False)
    assert mode.last_change.revision == reply.revision
    assert before - 1 <= mode.last_change.time_ns / 1e9 <= time.time() + 1
    assert speed.last_change.via == "start" and speed.last_change.verified
    assert dds.client().get(NODE, ["mode"]).results[0].last_change is None  # not asked


def test_history_pages_and_says_when_retention_dropped_part_of_it(dds: DdsSession) -> None:
    participant = dds.participant()
    server = ParameterServer(participant, retention=Retention(max_records=700)).start()
    server.add_node(_table())
    client = dds.client()
    for i in range(800):
        client.set(NODE, {"speed": (i % 200) / 100})
    reply = client.history(NODE)
    assert len(reply.records) == 700 and reply.compacted  # more than one page (500)
    assert [r.seq for r in reply.records] == list(range(reply.records[0].seq, reply.records[0].seq + 700))
    recent = client.history(NODE, since_revision=reply.records[-10].revision - 1)
    assert len(recent.records) == 10 and not recent.compacted
    server.close()
