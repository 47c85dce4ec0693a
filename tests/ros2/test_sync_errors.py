"""What a read of a mirrored node raises beyond a failed call is logged (``Mirror._sync``).

A real :class:`~paramdds.ros2.rosside.RosSide` and :class:`~paramdds.ros2.mirror.Mirror`, and a
real rclpy node to read; the hosting callback refuses.
"""

from __future__ import annotations

import time
from typing import Any

import pytest

from paramdds.ros2.mirror import Mirror

from .test_mirror import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(60)]

FQN = "/sync_errors/node"


def test_a_read_that_raises_is_logged_and_the_node_can_be_read_again(
    ros_env: dict[str, str], ros_hosts: Any, caplog: pytest.LogCaptureFixture
) -> None:
    """What a read raises beyond a failed call (here: hosting the node) would stay in the sync
    pool, the node left unhosted with nothing said; it is logged, and the node is free to be
    read again."""
    from paramdds.ros2.rosside import RosSide

    ros_hosts("--node", FQN)

    def host(_table: Any) -> None:
        raise RuntimeError("hosting refused")

    ros = RosSide(None, "sync_errors_test")
    mirror = Mirror(ros, host, lambda _n: None, lambda _n, _names: None, timeout=2.0, resync=0)
    try:
        with caplog.at_level("ERROR", logger="paramdds.ros2.mirror"):
            mirror.update({FQN: frozenset()}, time.monotonic())
            wait_for(lambda: "hosting refused" in caplog.text, 20, "the failed read logged")
        m = mirror.nodes[FQN]
        wait_for(lambda: not m.syncing, 5, "the node free to be read again")
    finally:
        mirror.close()
        ros.close()
