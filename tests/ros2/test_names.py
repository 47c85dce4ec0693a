"""A mirrored ROS 2 node's name in the Python monitor and in the CLI's JSON.

docs/python-api.md: a monitor's keys and ``NodeState.node`` are node ids, one form for
every node, without a leading slash (``synth/node_050``); the CLI writes a mirrored ROS 2
node as ROS 2 names it (``/synth/node_050``). ``NodeState.shown_name`` is that written form,
so a program matches the JSON without rebuilding it. Real rclpy node, real bridge.
"""

from __future__ import annotations

import json
from typing import Any

import pytest

from paramdds.core.monitor_events import NodeState

from .conftest import RosHost, paramdds_cli
from .test_mirror import paramdds_side, wait_for

__all__ = ["paramdds_side"]  # the fixture, used by name below


def test_shown_name_is_the_cli_form_of_each_kind_of_node() -> None:
    assert NodeState("synth/node_050", origin="ros2").shown_name == "/synth/node_050"
    assert NodeState("robot1").shown_name == "robot1"
    assert NodeState("fleet/robot1", origin=None).shown_name == "fleet/robot1"


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_the_monitor_and_nodes_json_name_a_mirrored_node_alike(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any
) -> None:
    host: RosHost = ros_hosts("--node", "/synth/node_050")
    client, monitor = paramdds_side
    client.wait_for_node("/synth/node_050", timeout=30)
    wait_for(lambda: "synth/node_050" in monitor.snapshot(), 10, "the monitor holds the mirror")
    out = paramdds_cli(ros_env, "nodes", "-o", "json")
    assert out.returncode == 0, out.stderr
    listed = {row["node"] for row in json.loads(out.stdout)}
    assert "/synth/node_050" in listed
    states = monitor.snapshot()
    state = states["synth/node_050"]  # keyed by node id
    assert state.node == "synth/node_050" and state.origin == "ros2"
    assert state.shown_name == "/synth/node_050"  # what the JSON says
    assert {st.shown_name for st in states.values() if st.online} >= listed
    assert host.nodes == ["/synth/node_050"]
