"""When a rescue participant comes to see a node that left stalled (``Mirror.sighted``): the
bridge asks between two looks at the graph, and looks at once when it does (docs/ros2.md).

A real :class:`~paramdds.ros2.mirror.Mirror` fed graphs as the bridge reads them, its rescue
participant made as the bridge's look makes it, and a real rclpy node in a process of its own
coming into that participant's view.
"""

from __future__ import annotations

import time
from typing import Any

import pytest

from paramdds.dds.filters import STALE

from .test_mirror import wait_for
from .test_returning import mirror

pytestmark = [pytest.mark.slow, pytest.mark.timeout(60)]

__all__ = ["mirror"]  # the fixture, used by name below

BACK, STOPPED = "/sighted/back", "/sighted/stopped"


def test_a_node_that_left_stalled_is_sighted_once_when_a_participant_new_to_it_sees_it(
    mirror: Any, ros_hosts: Any
) -> None:
    ros_hosts("--node", BACK, "--node", STOPPED)
    fqns = (BACK, STOPPED)
    wait_for(lambda: all(mirror.ros.event_publishers().get(f) for f in fqns), 10, "both in the graph")
    writers = mirror.ros.event_publishers()
    mirror.update({f: writers[f] for f in fqns}, time.monotonic())
    wait_for(lambda: all(mirror.nodes[f].hosted for f in fqns), 10, "both mirrored")
    mirror.nodes[BACK].table.status = STALE  # as the bridge's liveness probes leave a stalled process
    mirror.update({}, time.monotonic())  # both leave the graph: one stalled, one stopped cleanly
    assert mirror.sighted() == frozenset()  # no participant to ask yet
    mirror.found_again({}, time.monotonic())  # the bridge's look makes one, new to both
    sighted = wait_for(lambda: mirror.sighted(), 10, "a node in view of that participant")
    # only the node that left stalled (one that stopped cleanly is not looked for), and once
    assert sighted == {BACK}
    assert mirror.sighted() == frozenset()
    assert set(mirror.found_again({}, time.monotonic())) == {BACK}
