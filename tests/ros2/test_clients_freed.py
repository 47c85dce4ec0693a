"""The bridge's ROS 2 side gives back what each service client held once it is destroyed.

A real :class:`~paramdds.ros2.rosside.RosSide` reading a real rclpy node through
:class:`~paramdds.ros2.mirror.RosLink`, whose read clients live only while it reads.
"""

from __future__ import annotations

from typing import Any

import pytest

from paramdds.ros2.mirror import READS, RosLink

pytestmark = [pytest.mark.slow, pytest.mark.timeout(60)]

FQN = "/clients_freed/node"
READS_MADE = 20


def test_reading_a_node_again_and_again_leaves_nothing_in_the_callback_group(
    ros_env: dict[str, str], ros_hosts: Any
) -> None:
    """rclpy's callback group keeps a weak reference for every client made in it and never drops
    it when the client is destroyed (ros2/rclpy#1356): a bridge makes three read clients per
    read of a node, on every ROS 2 node start, so the group grew for as long as it ran."""
    from paramdds.ros2.rosside import RosSide

    ros_hosts("--node", FQN)
    ros = RosSide(None, "clients_freed_test")
    try:
        link = RosLink(ros, FQN, 5.0)
        held = len(ros.clients_group.entities)  # the side's own clients (type registration)
        for _ in range(READS_MADE):
            assert "use_sim_time" in link.fetch()  # every read reached the node
        assert link.calls["list_parameters"] == READS_MADE
        assert len(ros.clients_group.entities) == held, (
            f"{len(ros.clients_group.entities) - held} references left behind by "
            f"{READS_MADE * len(READS)} read clients made and destroyed"
        )
        link.close()
    finally:
        ros.close()
