"""What monitors and the CLI tell: isolated callbacks, duplicate hosts, honest ``watch``.

* One monitor callback that raises costs neither the other callbacks nor the rest of
  its batch.
* Two processes hosting one node id are reported: a warning from each server, and
  ``also_hosted_by`` in ``paramdds nodes``.
* ``watch`` says ``not_synced`` when the state did not settle within its timeout
  (here: a node announces five parameters and publishes none) instead of ``synced``.
"""

from __future__ import annotations

import json
import logging
import subprocess
import time

import pytest
from cyclonedds.pub import DataWriter

from paramdds.core.table import ParameterTable
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire

from .conftest import DDS, PARAMDDS, Proc, make_dds_env, paramdds_argv, start_server, wait


@pytest.mark.timeout(30)
def test_a_failing_monitor_callback_costs_nothing_else(
    domain_id: int, dds: DDS, caplog: pytest.LogCaptureFixture
) -> None:
    table = ParameterTable("cb")
    for i in range(5):
        table.declare(f"p{i}", i)
    seen: list[MonitorEvent] = []

    calls = [0]

    def broken(event: MonitorEvent) -> None:
        calls[0] += 1
        raise RuntimeError("a bug in the user's callback")

    monitor = dds.monitor(domain_id, on_event=broken)
    monitor.add_callback(seen.append)
    assert wait(lambda: any(e.event is EventKind.SYNCED for e in seen), 5.0)  # emitted past a failure too
    dds.server(domain_id, table)  # after both callbacks are in place

    def added() -> set[str]:
        return {e.name for e in seen if e.event is EventKind.ADDED}

    assert wait(lambda: added() == {f"p{i}" for i in range(5)}, 5.0), f"events were lost: {added()}"
    assert calls[0] >= 7  # the failing one was called for every event (synced, online, 5 added)
    assert any("monitor callback" in r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR)


def _nodes(domain: int) -> list[dict[str, object]]:
    out = subprocess.run(
        [PARAMDDS, "nodes", "-o", "json"],
        env=make_dds_env(domain),
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 0, out.stderr
    rows: list[dict[str, object]] = json.loads(out.stdout)
    return rows


@pytest.mark.slow
@pytest.mark.timeout(90)
def test_two_processes_hosting_one_node_are_reported(domain_id: int, procs: list[Proc]) -> None:
    first = start_server(domain_id, "-n", "twin")
    procs.append(first)
    (row,) = _nodes(domain_id)
    assert row["node"] == "twin" and row["also_hosted_by"] == []  # positive control: one host
    assert "also hosted by" not in first.stderr_text()
    time.sleep(2.0)  # the first server's start-up is long over when its twin appears
    second = start_server(domain_id, "-n", "twin")
    procs.append(second)
    (row,) = _nodes(domain_id)
    hosts = {row["pid"], *(int(str(d).split()[1]) for d in row["also_hosted_by"])}  # type: ignore[union-attr]
    assert hosts == {first.pid, second.pid}, json.dumps(row)
    # the server that started second says so itself, naming the first
    assert wait(lambda: f"also hosted by pid {first.pid}" in second.stderr_text(), 5.0), second.stderr_text()
    # and the first one, which follows other processes' claims of its nodes for good
    said = first.stderr_text
    assert wait(lambda: f"also hosted by pid {second.pid}" in said(), 5.0), said()


@pytest.mark.timeout(60)
def test_a_node_added_to_a_running_server_meets_the_twin_that_claimed_it_first(
    domain_id: int, dds: DDS, procs: list[Proc], caplog: pytest.LogCaptureFixture
) -> None:
    first = start_server(domain_id, "-n", "twin")
    procs.append(first)
    other = ParameterTable("other")
    other.declare("x", 1)
    server = dds.server(domain_id, other)  # started, hosting another node
    assert wait(lambda: "twin" in server._claimed, 5.0)  # the first server's claim arrived
    assert "also hosted by" not in caplog.text  # positive control: "other" has no twin
    table = ParameterTable("twin")
    table.declare("x", 2)
    server.add_node(table)
    assert f"'twin' is also hosted by pid {first.pid}" in caplog.text
    assert wait(lambda: "also hosted by pid" in first.stderr_text(), 5.0), first.stderr_text()


@pytest.mark.slow
@pytest.mark.timeout(60)
def test_watch_says_when_the_state_did_not_settle(domain_id: int, dds: DDS, procs: list[Proc]) -> None:
    table = ParameterTable("whole")
    table.declare("x", 1)
    dds.server(domain_id, table)
    watch = Proc(paramdds_argv("watch", "-o", "json", "--timeout", "1"), make_dds_env(domain_id))
    procs.append(watch)
    watch.wait_for('"synced"')  # positive control: a complete node settles

    participant = dds.participant(domain_id)
    writer = DataWriter(
        participant,
        make_topic(participant, "ParameterEvents", wire.ParameterEvent),
        QosProfiles.load().writer("ParameterEvents"),
    )
    # a node that announces five parameters and never publishes them
    writer.write(wire.ParameterEvent(node_id="partial", name="", kind=wire.EVENT_PRESENCE, parameter_count=5))
    late = Proc(paramdds_argv("watch", "-o", "json", "--timeout", "1"), make_dds_env(domain_id))
    procs.append(late)
    _, line = late.wait_for(lambda text: "synced" in text)
    event = json.loads(line)
    assert event["event"] == "not_synced" and event["waited"] >= 1.0
