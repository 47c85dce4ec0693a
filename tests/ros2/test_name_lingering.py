"""A mirrored node whose name outlives its endpoints in the ROS 2 graph is shown offline.

A ROS 2 process that stops destroys its nodes one by one; each destruction is one update of
the process's node list (``ros_discovery_info``: reliable, keep-last 1) and the removal of the
node's endpoints (DDS discovery). When the last updates, and the process's goodbye, are lost
as it exits, a peer's graph keeps the later nodes' names, without a single endpoint, until the
participant's lease (20 s), or for good when rmw processes a node list of the process after it
dropped the process. The host's ``strip`` gives a peer that graph for one node: its
name stays, its parameter services and ``/parameter_events`` writer go. The bridge shows it
offline, keeps it so while the name lingers, and mirrors the node again once a process has
it with its writer.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest

from paramdds.dds.monitor import ParameterMonitor
from paramdds.dds.participant import close_participant, make_participant
from paramdds.ros2.mirror import MIN_AGE, UNREACHABLE_AFTER

from .test_mirror import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

GONE, KEPT = "/lingering/gone", "/lingering/kept"


@pytest.fixture
def monitor(domain_id: int) -> Iterator[ParameterMonitor]:
    dp = make_participant(domain_id, localhost=True)
    m = ParameterMonitor(dp)
    yield m
    m.close()
    close_participant(dp)


def online(monitor: ParameterMonitor, fqn: str) -> bool:
    st = monitor.snapshot().get(fqn.lstrip("/"))
    return st is not None and st.online


def test_a_node_named_without_its_endpoints_is_shown_offline(
    ros_hosts: Any, bridge: Any, monitor: ParameterMonitor
) -> None:
    host = ros_hosts("--node", GONE, "--node", KEPT, "--threads", "1")
    wait_for(lambda: online(monitor, GONE) and online(monitor, KEPT), 30, "both nodes mirrored")
    assert host.command(f"strip {GONE}") == "stripped"
    wait_for(lambda: GONE not in bridge.ros.event_publishers(), 10, "its writer out of the bridge's graph")
    assert GONE in bridge.ros.graph()  # the name lingers, as a lost update leaves it
    wait_for(lambda: not online(monitor, GONE), 5, "the lingering name shown offline")
    # and it stays so: not mirrored again, not shown unreachable, while the name lingers
    time.sleep(MIN_AGE + UNREACHABLE_AFTER + 1.5)
    assert GONE in bridge.ros.graph()
    assert not online(monitor, GONE) and bridge.unreachable == []
    assert online(monitor, KEPT)
    # a process that has the node (with its writer) is mirrored, the name lingering or not
    ros_hosts("--node", GONE, "--threads", "1")
    wait_for(lambda: online(monitor, GONE), 20, "the node of a new process mirrored")
    assert online(monitor, KEPT)
