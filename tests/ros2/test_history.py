"""The bridge stamps what comes from ROS 2: history says via ros2, and which node reported it."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from paramdds.core.history import Outcome
from paramdds.core.values import ParameterValue
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.server import ParameterServer

from .conftest import RosHost, oracle
from .test_expose import twin_table
from .test_mirror import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]

NODE = "robot/rich"


@pytest.fixture
def alice(domain_id: int) -> Iterator[ParameterClient]:
    """A paramdds client of its own, claiming to be alice."""
    dp = make_participant(domain_id, localhost=True)
    client = ParameterClient(dp, timeout=10.0, as_="alice")
    yield client
    client.close()
    close_participant(dp)


def _speed(client: ParameterClient) -> object:
    return client.get(NODE, ["limits.speed"]).values()["limits.speed"].value


def test_a_ros2_set_on_a_mirrored_node_is_recorded_as_that_nodes_via_ros2(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, alice: ParameterClient
) -> None:
    ros_hosts("--rich", "/robot/rich")
    alice.wait_for_node(NODE, timeout=30)
    # another ROS 2 node's client sets it, as `ros2 param set` does
    assert oracle(ros_env, "set", "/robot/rich", "limits.speed", "4.25") == [True, ""]
    wait_for(lambda: _speed(alice) == 4.25, 20, "the ROS 2 change mirrored")
    (last,) = alice.history(NODE, ["limits.speed"], outcome=Outcome.APPLIED).records[-1:]
    assert (last.who, last.via, last.verified) == ("/robot/rich", "ros2", False)
    assert (last.old, last.new) == (ParameterValue.from_python(1.5), ParameterValue.from_python(4.25))
    # a set forwarded from paramdds keeps its asker, though the node's event echoes it (and
    # may arrive before the node's answer)
    for speed in (1.0, 2.0, 3.0, 2.5, 0.5):
        assert alice.set(NODE, {"limits.speed": speed}).successful
    wait_for(lambda: _speed(alice) == 0.5, 20, "the forwarded sets mirrored")
    records = alice.history(NODE, ["limits.speed"], outcome=Outcome.APPLIED).records
    assert [(r.who, r.via) for r in records[-5:]] == [("alice", "api")] * 5
    assert [r.new for r in records[-5:]] == [ParameterValue.from_python(s) for s in (1.0, 2.0, 3.0, 2.5, 0.5)]


@pytest.fixture
def exposed(ros_env: dict[str, str], domain_id: int) -> Iterator[ParameterServer]:
    """A paramdds node (robot/rich) and a bridge exposing it to ROS 2; yields its server."""
    from paramdds.ros2.bridge import Bridge, BridgeOptions

    dp = make_participant(domain_id, localhost=True)
    server = ParameterServer(dp)
    server.add_node(twin_table(NODE))
    server.start()
    bridge_dp = make_participant(domain_id, localhost=True)
    bridge = Bridge(bridge_dp, None, BridgeOptions(expose=("robot/*",), timeout=5.0, resync=0)).start()
    yield server
    bridge.close()
    close_participant(bridge_dp)
    server.close()
    close_participant(dp)


def test_a_ros2_set_through_an_exposed_node_is_recorded_via_ros2(
    ros_env: dict[str, str], exposed: ParameterServer, alice: ParameterClient
) -> None:
    alice.wait_for_node(NODE, timeout=30)
    assert oracle(ros_env, "set", "/robot/rich", "limits.speed", "2.75") == [True, ""]
    assert oracle(ros_env, "set", "/robot/rich", "mode", '"wrong"')[0] is False  # refused by the node
    records = alice.history(NODE, ["limits.speed", "mode"]).records
    applied = [r for r in records if r.applied and r.via != "start"]
    refused = [r for r in records if not r.applied]
    assert [(r.name, r.who, r.via, r.verified) for r in applied] == [("limits.speed", "ros2", "ros2", False)]
    assert applied[0].new == ParameterValue.from_python(2.75)
    assert [(r.name, r.who, r.via) for r in refused] == [("mode", "ros2", "ros2")]
    assert "auto or manual" in refused[0].reason


def test_a_mirrored_nodes_own_change_is_its_report(ros_hosts: Any, bridge: Any) -> None:
    """A change the node's own code makes (its set_parameters) is recorded as the node's."""
    host: RosHost = ros_hosts("--rich", "/robot/rich")
    wait_for(lambda: NODE in bridge.server.nodes, 30, "the node mirrored")
    assert host.command("set /robot/rich limits.count 6") == "set ok"
    table = bridge.server.nodes[NODE]
    six = ParameterValue.from_python(6)
    wait_for(lambda: table.get_many(["limits.count"])[0].value == six, 20, "the change mirrored")
    last = bridge.server.history(NODE).last("limits.count")
    assert last is not None and (last.who, last.via, last.verified) == ("/robot/rich", "ros2", False)
