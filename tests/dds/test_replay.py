"""ReplayWatch over real DDS: history after a revision, then live changes, each once, in order,
even when the live reader skips revisions (here: every other event dropped on purpose)."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from paramdds.core.history import HistoryRecord, Retention
from paramdds.core.monitor_events import MonitorEvent
from paramdds.core.replay import Gap
from paramdds.core.table import ParameterTable
from paramdds.dds.replay import ReplayWatch
from paramdds.dds.server import ParameterServer

from .helpers import DdsSession

pytestmark = pytest.mark.timeout(60)

NODE = "robot"


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


class Collected:
    def __init__(self) -> None:
        self.items: list[HistoryRecord | Gap] = []
        self.cond = threading.Condition()

    def __call__(self, item: HistoryRecord | Gap) -> None:
        with self.cond:
            self.items.append(item)
            self.cond.notify_all()

    def wait_revision(self, revision: int) -> None:
        with self.cond:
            assert self.cond.wait_for(
                lambda: any(isinstance(i, HistoryRecord) and i.revision >= revision for i in self.items), 10
            ), self.items


def _table() -> ParameterTable:
    t = ParameterTable(NODE)
    t.declare("a", 0)
    t.declare("b", 0)
    return t


def test_skipped_live_revisions_are_read_from_history(dds: DdsSession) -> None:
    dds.server(_table())
    client = dds.client(as_="writer")
    client.wait_for_node(NODE)
    for v in range(1, 4):
        client.set(NODE, {"a": v})
    since = client.history(NODE).records[-1].revision - 1  # the last of the three changes comes again
    got = Collected()
    watch = ReplayWatch(client, NODE, since, got)
    seen = [0]

    def lossy(event: MonitorEvent) -> None:  # a reader that falls behind: every other change lost
        seen[0] += 1
        if seen[0] % 2:
            watch.on_event(event)

    monitor = dds.monitor(nodes=[NODE], on_event=lossy)
    assert monitor.wait_complete([NODE], 10)
    watch.replay()
    for v in range(10, 40):
        last = client.set(NODE, {"a": v, "b": -v}).revision
    got.wait_revision(last)
    watch.close()
    records = [i for i in got.items if isinstance(i, HistoryRecord)]
    assert not [i for i in got.items if isinstance(i, Gap)]
    expected = [r for r in client.history(NODE, since_revision=since).records if r.applied]
    assert [(r.revision, r.name, r.new) for r in records] == [(r.revision, r.name, r.new) for r in expected]
    assert {r.who for r in records} == {"writer"}


def test_revisions_retention_dropped_are_a_gap(dds: DdsSession) -> None:
    server = ParameterServer(dds.participant("paramdds-test-server"), retention=Retention(max_records=4))
    server.add_node(_table())
    server.start()
    try:
        client = dds.client()
        client.wait_for_node(NODE)
        for v in range(1, 10):
            client.set(NODE, {"a": v})
        got = Collected()
        watch = ReplayWatch(client, NODE, 1, got)
        reply = watch.replay()
        watch.close()
    finally:
        server.close()
    assert reply.compacted
    gap, *records = got.items
    assert isinstance(gap, Gap) and gap.after == 1
    revisions = [r.revision for r in records if isinstance(r, HistoryRecord)]
    assert revisions == list(range(gap.before, gap.before + 4))
