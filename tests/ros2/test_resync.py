"""The bridge's periodic resynchronization: only the values, paced over the period.

``/parameter_events`` carries every change, so the periodic pass asks each mirrored node
for its values alone (one ``get_parameters``; no list, no describe) and repairs what
differs; and it is paced, one node every ``resync / nodes`` seconds, so the nodes a
bridge read together at its start are not all asked again in the same second. Real
rclpy nodes in a process of their own, real bridge.
"""

from __future__ import annotations

import time
from collections import Counter
from typing import Any

import pytest

from paramdds.dds.participant import close_participant, make_participant

from .test_mirror import paramdds_side, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

__all__ = ["paramdds_side"]  # the fixture, used by name below

NODES = 12
PERIOD = 3.0


def test_the_periodic_resync_reads_only_values_spread_over_the_period(
    ros_env: dict[str, str], ros_hosts: Any, domain_id: int, paramdds_side: Any
) -> None:
    from paramdds.ros2.bridge import Bridge, BridgeOptions

    host = ros_hosts(*[a for i in range(NODES) for a in ("--node", f"/spread/n{i:02d}")])
    _, monitor = paramdds_side
    dp = make_participant(domain_id, localhost=True)
    bridge = Bridge(dp, None, BridgeOptions(timeout=2.0, resync=PERIOD)).start()
    try:
        wait_for(
            lambda: all((st := monitor.snapshot().get(n.lstrip("/"))) and st.online for n in host.nodes),
            30,
            "every node mirrored",
        )
        links = [m.link for m in bridge.mirror.nodes.values()]
        assert len(links) == NODES
        before = sum((Counter(link.calls) for link in links), Counter())
        started = time.monotonic()
        time.sleep(2 * PERIOD + 1.0)
        after = sum((Counter(link.calls) for link in links), Counter())
        made = after - before
        # only the values: no list, no describe (they were two of every three calls)
        assert made["list_parameters"] == 0 and made["describe_parameters"] == 0, made
        assert made["get_parameters"] >= NODES, made  # every node checked in two periods
        # paced: at most resync / nodes apart plus one look's worth in any second, where
        # a start's reads all fell due within a quarter of the period
        checks = sorted(t for t, _ in bridge.mirror.checks if t >= started)
        busiest = max(sum(1 for u in checks if t <= u < t + 1.0) for t in checks)
        assert busiest <= NODES / PERIOD + 3, (busiest, checks)
        assert bridge.mirror.missed == 0  # the events said it all
    finally:
        bridge.close()
        close_participant(dp)
