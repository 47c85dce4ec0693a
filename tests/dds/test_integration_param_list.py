"""A parameter list end to end: a server process loads examples/params.yaml (7 parameters); a
monitor and a late client (list, get, set) see it over real Cyclone on loopback."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from paramdds.core.values import ParameterValue
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.formats.paramlist import load_param_list

from .helpers import DdsSession, ServerProc

pytestmark = pytest.mark.timeout(60)

LIST_FILE = Path(__file__).resolve().parents[2] / "examples" / "params.yaml"
NODE = "robot1"

NEW_VALUES = {
    "robot.max_velocity": 2.5,
    "robot.max_acceleration": 1.25,
    "robot.name": "renamed",
    "robot.enabled": False,
    "robot.wheel_count": 6,
    "sensor.frequencies": [1.0, 2.0],
    "sensor.topics": ["/a", "/b", "/c", "/d"],
}


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def test_example_list_is_served_listed_got_set_and_watched(dds: DdsSession) -> None:
    params = {p.name: p.value for p in load_param_list(LIST_FILE)}
    assert len(params) == 7

    events: list[MonitorEvent] = []
    lock = threading.Lock()

    def record(event: MonitorEvent) -> None:
        with lock:
            events.append(event)

    monitor = dds.monitor(on_event=record)
    with ServerProc(dds.domain_id, [{"id": NODE, "param_list": str(LIST_FILE)}]) as server:
        # the monitor was there first: it sees the node join with its 7 parameters
        assert monitor.wait_complete([NODE], timeout=5.0)
        state = monitor.snapshot()[NODE]
        assert state.online and state.pid == server.pid
        assert set(state.parameters) == set(params)
        for name, value in params.items():
            assert state.parameters[name][0].same_as(value), name

        client = dds.client()  # the late client
        listed = client.list(NODE)
        assert sorted(listed.names) == sorted(params)

        got = client.get(NODE, list(params))
        assert [r.name for r in got.results] == list(params)
        assert all(r.code is None for r in got.results)
        for name, value in got.values().items():
            assert value.same_as(params[name]), name
        start_revision = got.revision

        revisions = []
        for name, value in NEW_VALUES.items():
            reply = client.set(NODE, {name: value})
            assert reply.successful, reply.results
            revisions.append(reply.revision)
        assert revisions == list(range(start_revision + 1, start_revision + 8))

        final = client.get(NODE, list(NEW_VALUES)).values()
        for name, value in NEW_VALUES.items():
            assert final[name].same_as(ParameterValue.from_python(value)), name

        assert monitor.wait_until(lambda s: s[NODE].revision == revisions[-1], timeout=5.0)

        with lock:
            param_events = [e for e in events if e.event in (EventKind.ADDED, EventKind.MODIFIED)]
        added = [e for e in param_events if e.event is EventKind.ADDED]
        modified = [e for e in param_events if e.event is EventKind.MODIFIED]
        assert sorted(e.name for e in added) == sorted(params)
        assert {e.name for e in added} == set(params)
        # one modified event per set, each with its own revision, in order
        assert [(e.name, e.revision) for e in modified] == list(zip(NEW_VALUES, revisions, strict=True))
        for e in modified:
            assert e.value is not None
            assert e.value.same_as(ParameterValue.from_python(NEW_VALUES[e.name]))
        assert any(e.event is EventKind.ONLINE and e.node == NODE for e in events)
        assert not any(e.event is EventKind.DELETED for e in events)
