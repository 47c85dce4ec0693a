"""Blame in the state: each parameter's state sample carries its last change, end to end.

A server publishes every change with the origin and time its commit was stamped with
(who, verified, via, stamp, revision); a monitor, live or joining late, holds it per
parameter and puts it on its events. A node it starts hosting is published with each
parameter's last change from its history, where it has one.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from paramdds.core.origin import Origin, Via, acting, local_identity
from paramdds.core.results import LastChange
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterValue
from paramdds.dds.monitor import EventKind, MonitorEvent

from .helpers import DdsSession, wait_until

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


class Recorder:
    def __init__(self) -> None:
        self.events: list[MonitorEvent] = []
        self._lock = threading.Lock()

    def __call__(self, event: MonitorEvent) -> None:
        with self._lock:
            self.events.append(event)

    def modified(self, name: str) -> list[MonitorEvent]:
        with self._lock:
            return [e for e in self.events if e.event is EventKind.MODIFIED and e.name == name]


def test_a_change_is_published_with_its_blame_and_a_late_monitor_holds_it(dds: DdsSession) -> None:
    table = ParameterTable("blamed")
    table.declare("speed", 1.0)
    table.declare("name", "r1")
    dds.server(table)
    live = Recorder()
    monitor = dds.monitor(on_event=live)
    assert monitor.wait_complete(["blamed"], timeout=10)
    started = monitor.last_change("blamed", "speed")  # the value the node started with
    assert started is not None and (started.who, started.verified, started.via) == (
        local_identity(),
        True,
        "start",
    )

    with acting(Origin("alice@robot-host", Via.CLI)):
        change = table.set([Parameter("speed", ParameterValue.from_python(2.5))]).change
    assert change is not None and change.time_ns > 0
    alice = LastChange("alice@robot-host", False, "cli", change.time_ns, change.revision)
    assert wait_until(lambda: bool(live.modified("speed")), 10)
    got = live.modified("speed")[0].last_change
    assert got is not None
    # the stamp is the commit's time, not the publication's (read back through a float: ~0.2 µs)
    assert abs(got.time_ns - alice.time_ns) < 1_000
    assert got == LastChange(alice.who, alice.verified, alice.via, got.time_ns, alice.revision)

    late = dds.monitor()
    assert late.wait_complete(["blamed"], timeout=10)
    held = late.last_change("blamed", "speed")
    assert held is not None and (held.who, held.verified, held.via, held.revision) == (
        "alice@robot-host",
        False,
        "cli",
        change.revision,
    )
    assert held.to_json()["time"] == got.to_json()["time"]
    assert late.last_change("blamed", "name") == started  # one start for the whole table


def test_a_node_starting_to_be_hosted_is_published_with_each_parameters_last_change(
    dds: DdsSession,
) -> None:
    table = ParameterTable("restored")
    table.declare("speed", 1.0)
    table.declare("name", "r1")
    server = dds.server()
    last = {"speed": LastChange("bob", True, "web", 1_700_000_000_123_456_000, 7)}
    server.publication.begin(table, last)  # what the server does with the node's history
    monitor = dds.monitor()
    assert wait_until(lambda: monitor.last_change("restored", "speed") is not None, 10)
    assert monitor.last_change("restored", "speed") == last["speed"]
    assert monitor.last_change("restored", "name") is None  # no change known: no author
    states = monitor.snapshot()["restored"]
    assert states.parameters["speed"][0] == ParameterValue.from_python(1.0)
