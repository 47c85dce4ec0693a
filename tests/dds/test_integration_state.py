"""Node state on ParameterEvents: late joiners, presence, graceful stop, killed and restarted servers.

Trap 1 (docs/wire.md): events keyed by node_id alone keep the last *change*; keyed by
(node_id, name) they keep the whole table, so a late monitor sees exactly the
current state. The autodispose trap: a graceful stop must look like "offline",
never like every parameter being deleted.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator

import pytest

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.values import NOT_SET, Parameter, ParameterValue
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.errors import UnavailableError

from .helpers import DdsSession, ServerProc, wait_until

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


class Recorder:
    """Collects monitor events (they arrive on the monitor's dispatch thread)."""

    def __init__(self) -> None:
        self.events: list[MonitorEvent] = []
        self._lock = threading.Lock()

    def __call__(self, event: MonitorEvent) -> None:
        with self._lock:
            self.events.append(event)

    def of(self, *kinds: EventKind) -> list[MonitorEvent]:
        with self._lock:
            return [e for e in self.events if e.event in kinds]


# -- trap 1: a late joiner sees the full current state -------------------------------------------


def test_late_monitor_sees_exact_state_after_1000_changes(dds: DdsSession) -> None:
    node = "busy"
    table = ParameterTable(node, allow_undeclared=True)
    for i in range(40):  # dynamically typed: may change type and be deleted
        table.declare(f"dyn.p{i:02}", i, ParameterDescriptor("", dynamic_typing=True))
    for i in range(10):  # statically typed
        table.declare(f"static.s{i}", float(i))
    dds.server(table)
    client = dds.client()
    client.wait_for_node(node, timeout=5.0)

    dyn = [f"dyn.p{i:02}" for i in range(40)]
    added: list[str] = []
    changes = 0
    for i in range(1000):
        if i % 10 == 3 and dyn:  # delete a dynamic parameter
            params = [Parameter(dyn.pop(i % len(dyn)), NOT_SET)]
        elif i % 10 == 7 and added:  # delete one added earlier
            params = [Parameter(added.pop(0), NOT_SET)]
        elif i % 5 == 1:  # add an undeclared one
            added.append(f"added.a{i}")
            params = [Parameter(added[-1], ParameterValue.from_python(f"v{i}"))]
        elif i % 2 and dyn:  # change a dynamic one, sometimes its type
            value: object = [i, i + 1] if i % 3 == 0 else f"s{i}" if i % 3 == 1 else i * 0.5
            params = [Parameter(dyn[i % len(dyn)], ParameterValue.from_python(value))]
        else:
            params = [Parameter(f"static.s{i % 10}", ParameterValue.from_python(i + 0.25))]
        reply = client.set(node, params)
        assert reply.successful, (i, reply.results)
        changes += 1
    assert changes == 1000

    truth = {name: value for name, value, _ in table.snapshot()}
    assert 30 < len(truth) < 200  # deletes and adds both happened

    monitor = dds.monitor()  # the late joiner
    assert monitor.wait_complete([node], timeout=5.0)
    state = monitor.snapshot()[node]
    assert state.online
    assert state.revision == table.revision
    assert set(state.parameters) == set(truth)  # deleted ones absent, added ones present
    for name, value in truth.items():
        assert state.parameters[name][0].same_as(value), name
        assert state.parameters[name][1].type is value.type, name
    assert len(state.parameters) == len(table) == state.announced


# -- presence ------------------------------------------------------------------------------------


def test_node_with_zero_parameters_is_visible(dds: DdsSession) -> None:
    dds.server(ParameterTable("empty"))
    client = dds.client()
    info = client.wait_for_node("/empty", timeout=5.0)  # "/empty" and "empty" name one node
    assert info.node == "empty" and info.online
    assert info.parameters == 0 and info.pid == os.getpid()
    assert [n.node for n in client.nodes()] == ["empty"]
    listed = client.list("empty")
    assert listed.names == () and listed.prefixes == ()


def test_nodes_survive_the_dispose_of_a_parameter_the_presence_reader_filters_out(dds: DdsSession) -> None:
    """A delete disposes a parameter's instance: the client's presence reader (which filters
    parameter samples out) gets it as a sample without data, which ``nodes()`` must skip."""
    dds.server(ParameterTable("scratch", allow_undeclared=True))
    client = dds.client()
    client.wait_for_node("scratch", timeout=5.0)
    assert client.set("scratch", [Parameter("tmp", ParameterValue.from_python(1))]).successful
    deleted = client.delete("scratch", ["tmp"])
    assert deleted.successful
    assert wait_until(lambda: getattr(client.node_info("scratch"), "revision", 0) == deleted.revision, 5.0)
    nodes = client.nodes()
    assert [(n.node, n.online, n.parameters) for n in nodes] == [("scratch", True, 0)]


def test_unknown_node_fails_fast_with_unavailable(dds: DdsSession) -> None:
    dds.server(ParameterTable("present"))
    fresh = dds.client()  # still inside its presence grace period
    started = time.monotonic()
    with pytest.raises(UnavailableError, match="ghost"):
        fresh.get("ghost", ["x"], timeout=10.0)
    assert time.monotonic() - started < 1.5  # the grace (1 s), not the 10 s timeout

    fresh.wait_for_node("present", timeout=5.0)
    assert fresh.list("present").names == ()  # the system was reachable all along
    started = time.monotonic()
    with pytest.raises(UnavailableError):
        fresh.set("ghost", {"x": 1}, timeout=10.0)  # grace over: at once
    assert time.monotonic() - started < 0.5


# -- graceful stop: offline, not deleted (autodispose trap) ----------------------------------------


def test_graceful_close_in_process_is_offline_not_deleted(dds: DdsSession) -> None:
    table = ParameterTable("calm")
    table.declare("a", 1)
    table.declare("b", "two")
    recorder = Recorder()
    monitor = dds.monitor(on_event=recorder)
    server = dds.server(table)
    assert monitor.wait_complete(["calm"], timeout=5.0)

    server.close()
    assert monitor.wait_until(lambda s: not s["calm"].online, timeout=3.0)
    state = monitor.snapshot()["calm"]
    assert set(state.parameters) == {"a", "b"}
    assert state.parameters["a"][0].same_as(ParameterValue.from_python(1))
    assert recorder.of(EventKind.DELETED) == []
    assert [e.node for e in recorder.of(EventKind.OFFLINE)] == ["calm"]


def test_sigterm_server_is_offline_and_keeps_values(dds: DdsSession) -> None:
    recorder = Recorder()
    monitor = dds.monitor(on_event=recorder)
    with ServerProc(dds.domain_id, [{"id": "term", "params": {"x": 1.5, "y": "why"}}]) as server:
        assert monitor.wait_complete(["term"], timeout=5.0)
        assert server.terminate(timeout=10.0) == 0
        server.expect("CLOSED", 1.0)
    assert monitor.wait_until(lambda s: not s["term"].online, timeout=3.0)
    state = monitor.snapshot()["term"]
    assert state.parameters["x"][0].same_as(ParameterValue.from_python(1.5))
    assert state.parameters["y"][0].same_as(ParameterValue.from_python("why"))
    assert recorder.of(EventKind.DELETED) == []
    assert [e.node for e in recorder.of(EventKind.OFFLINE)] == ["term"]


# -- stopped, then resumed: offline, then online again without a change ------------------------------


@pytest.mark.slow
def test_a_server_stopped_past_its_lease_comes_back_online_when_it_resumes(dds: DdsSession) -> None:
    node = {"id": "sleeper", "params": {"speed": 3}}
    recorder = Recorder()
    monitor = dds.monitor(on_event=recorder)
    client = dds.client(timeout=5.0)
    with ServerProc(dds.domain_id, [node]) as server:
        assert monitor.wait_complete(["sleeper"], timeout=5.0)
        server.freeze()
        assert monitor.wait_until(lambda s: not s["sleeper"].online, timeout=3.0)
        server.thaw()
        # nothing changes on the node: its presence alone must bring it back
        assert monitor.wait_until(lambda s: s["sleeper"].online, timeout=3.0)
        assert wait_until(lambda: getattr(client.node_info("sleeper"), "online", False), 3.0)
        assert client.get_value("sleeper", "speed").value == 3
        assert monitor.snapshot()["sleeper"].parameters["speed"][0].value == 3
    kinds = [e.event for e in recorder.of(EventKind.ONLINE, EventKind.OFFLINE)]
    assert kinds[:3] == [EventKind.ONLINE, EventKind.OFFLINE, EventKind.ONLINE]


# -- killed server: offline fast, calls fail fast, restart seen online --------------------------------


@pytest.mark.slow
def test_killed_server_offline_fast_calls_fail_fast_and_restart_online(dds: DdsSession) -> None:
    node = {"id": "victim", "params": {"speed": 3, "label": "v1"}}
    recorder = Recorder()
    monitor = dds.monitor(on_event=recorder)
    client = dds.client(timeout=10.0)
    with ServerProc(dds.domain_id, [node]) as server:
        assert monitor.wait_complete(["victim"], timeout=5.0)
        assert client.set("victim", {"speed": 4}).successful
        assert monitor.wait_until(lambda s: s["victim"].parameters["speed"][0].value == 4, timeout=3.0)

        # A frozen server: the call is pending when the node's liveliness lapses.
        server.freeze()
        stopped = time.monotonic()
        with pytest.raises(UnavailableError, match="victim"):
            client.get("victim", ["speed"])  # timeout 10 s
        assert time.monotonic() - stopped < 3.0, "a pending call must fail when the node goes offline"
        assert monitor.wait_until(
            lambda s: not s["victim"].online, timeout=1.5 - (time.monotonic() - stopped)
        )
        assert time.monotonic() - stopped < 1.5

        server.kill()
        started = time.monotonic()
        with pytest.raises(UnavailableError):
            client.set("victim", {"speed": 5})
        assert time.monotonic() - started < 0.5, "a call to an offline node must fail at once"

    state = monitor.snapshot()["victim"]  # last values kept
    assert state.parameters["speed"][0].value == 4
    assert state.parameters["label"][0].value == "v1"
    assert recorder.of(EventKind.DELETED) == []

    with ServerProc(dds.domain_id, [node]) as restarted:
        assert monitor.wait_until(
            lambda s: s["victim"].online and s["victim"].pid == restarted.pid, timeout=5.0
        )
        assert wait_until(lambda: getattr(client.node_info("victim"), "pid", 0) == restarted.pid, 5.0)
        assert client.wait_for_node("victim", timeout=1.0).online
        assert client.get_value("victim", "speed").value == 3  # the restarted node's default
        assert client.set("victim", {"speed": 6}).successful
        assert client.get_value("victim", "speed").value == 6
    kinds = [e.event for e in recorder.of(EventKind.ONLINE, EventKind.OFFLINE)]
    assert kinds[:3] == [EventKind.ONLINE, EventKind.OFFLINE, EventKind.ONLINE]
