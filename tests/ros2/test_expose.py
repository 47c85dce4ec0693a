"""paramdds nodes exposed to ROS 2: a real rclpy client gets what it gets from an rclpy twin."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import pytest

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from paramdds.core.results import SetVeto
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.server import ParameterServer

from .conftest import ORACLE, oracle
from .test_mirror import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]


def twin_table(node_id: str) -> ParameterTable:
    """The parameters of ``python -m paramdds.bench.ros2_host --rich``, declared on paramdds."""
    t = ParameterTable(node_id)
    t.declare("use_sim_time", False)
    t.declare("start_type_description_service", True, ParameterDescriptor("", read_only=True))
    t.declare(
        "limits.speed",
        1.5,
        ParameterDescriptor(
            "", description="top speed (m/s)", floating_point_range=FloatingPointRange(0.0, 5.0, 0.0)
        ),
    )
    t.declare(
        "limits.count",
        4,
        ParameterDescriptor("", description="how many", integer_range=IntegerRange(0, 10, 2)),
    )
    t.declare("frozen", "ice", ParameterDescriptor("", read_only=True, description="never changes"))
    t.declare("anything", 3, ParameterDescriptor("", dynamic_typing=True))
    t.declare("mode", "auto", ParameterDescriptor("", additional_constraints="one of: auto, manual"))
    t.declare("gains", (1.0, 2.0, 3.0))
    t.declare("flags", (True, False))
    t.declare("ids", (1, 2, 3))
    t.declare("labels", ("a", "b"))

    def check(params: list[Parameter]) -> SetVeto:
        for p in params:
            if p.name == "mode" and p.value.value not in ("auto", "manual"):
                return SetVeto(False, f"mode must be auto or manual, not {p.value.value!r}")
        return SetVeto(True)

    t.add_on_set_callback(check)
    return t


@pytest.fixture
def exposing_bridge(ros_env: dict[str, str], domain_id: int) -> Iterator[Any]:
    from paramdds.ros2.bridge import Bridge, BridgeOptions

    dp = make_participant(domain_id, localhost=True)
    server = ParameterServer(dp)
    server.add_node(twin_table("robot/rich"))
    server.start()
    bridge_dp = make_participant(domain_id, localhost=True)
    bridge = Bridge(bridge_dp, None, BridgeOptions(expose=("robot/*",), timeout=5.0, resync=0)).start()
    yield bridge
    bridge.close()
    close_participant(bridge_dp)
    server.close()
    close_participant(dp)


def test_an_rclpy_client_gets_the_same_outcomes_from_an_exposed_node_as_from_an_rclpy_twin(
    ros_env: dict[str, str], ros_hosts: Any, exposing_bridge: Any
) -> None:
    ros_hosts("--rich", "/twin/rich")
    wait_for(lambda: "robot/rich" in exposing_bridge.exposer.nodes, 20, "the node exposed")
    twin = oracle(ros_env, "scenario", "/twin/rich")
    exposed = oracle(ros_env, "scenario", "/robot/rich")
    assert len(exposed) == len(twin) == 15
    for step_twin, step_exposed in zip(twin, exposed, strict=True):
        assert step_exposed == step_twin
    # the sets really happened (the first atomic set applied, the second refused as a whole)
    assert exposed[-2] == [
        "get",
        ["limits.speed", "mode", "limits.count"],
        [{"type": 3, "value": 1.0}, {"type": 4, "value": "manual"}, {"type": 2, "value": 6}],
    ]
    assert exposed[-4][2] == [True, False] and exposed[-3][2] == [
        False,
        True,
    ]  # the second one refused, saying why


def test_an_exposed_node_is_never_mirrored_back(
    ros_env: dict[str, str], exposing_bridge: Any, domain_id: int
) -> None:
    wait_for(lambda: "robot/rich" in exposing_bridge.exposer.nodes, 20, "the node exposed")
    # its ROS 2 node is in the graph, in the bridge's enclave: the mirror leaves it alone
    assert "/robot/rich" in exposing_bridge.ros.graph()
    exposing_bridge.step()
    assert "/robot/rich" not in exposing_bridge.mirror.nodes
    dp = make_participant(domain_id, localhost=True)
    try:
        with ParameterClient(dp) as client:
            info = client.wait_for_node("robot/rich", timeout=10)
            assert info.origin is None  # still the native node, hosted once
    finally:
        close_participant(dp)


def _events_of(ros_env: dict[str, str], domain_id: int, change: Any) -> list[Any]:
    """The /parameter_events messages of /robot/rich an rclpy subscriber gets for ``change(client)``."""
    listener = subprocess.Popen(
        [sys.executable, str(ORACLE), "events", "/robot/rich"],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    dp = make_participant(domain_id, localhost=True)
    try:
        assert listener.stdout is not None
        assert listener.stdout.readline().strip() == "listening"
        with ParameterClient(dp) as client:
            change(client)
        out, _ = listener.communicate(timeout=30)
    finally:
        close_participant(dp)
        if listener.poll() is None:
            listener.kill()
            listener.communicate()
    events: list[Any] = json.loads(out)
    return events


def test_an_exposed_nodes_changes_reach_ros2_parameter_events(
    ros_env: dict[str, str], exposing_bridge: Any, domain_id: int
) -> None:
    wait_for(lambda: "robot/rich" in exposing_bridge.exposer.nodes, 20, "the node exposed")

    def change(client: ParameterClient) -> None:
        assert client.set("robot/rich", {"limits.speed": 4.5}).successful

    (event,) = _events_of(ros_env, domain_id, change)
    assert event == {"new": [], "changed": [["limits.speed", {"type": 3, "value": 4.5}]], "deleted": []}


def test_an_atomic_set_on_an_exposed_node_is_one_parameter_event_as_rclpy_sends(
    ros_env: dict[str, str], exposing_bridge: Any, domain_id: int
) -> None:
    """Two messages for one atomic set showed subscribers a half-applied state; a plain set of
    two parameters is one message too (rclpy sends one per set), and the next set another."""
    wait_for(lambda: "robot/rich" in exposing_bridge.exposer.nodes, 20, "the node exposed")

    def change(client: ParameterClient) -> None:
        assert client.set("robot/rich", {"limits.speed": 2.5, "mode": "manual"}, atomic=True).successful
        assert client.set("robot/rich", {"limits.count": 6, "anything": "text"}).successful

    def changed(*items: tuple[str, int, object]) -> dict[str, Any]:
        return {"new": [], "changed": [[n, {"type": t, "value": v}] for n, t, v in items], "deleted": []}

    assert _events_of(ros_env, domain_id, change) == [
        changed(("limits.speed", 3, 2.5), ("mode", 4, "manual")),
        changed(("limits.count", 2, 6), ("anything", 4, "text")),
    ]


def test_two_bridges_never_loop_a_node(
    ros_env: dict[str, str], ros_hosts: Any, exposing_bridge: Any, domain_id: int
) -> None:
    """Bridge A exposes the paramdds node robot/rich and mirrors /twin/rich; bridge B mirrors
    and exposes everything it may: it mirrors neither A's exposed node (bridge enclave) nor
    what is already on paramdds, and exposes none of A's mirrors (origin ros2)."""
    from paramdds.ros2.bridge import POLL, Bridge, BridgeOptions

    ros_hosts("--rich", "/twin/rich")
    wait_for(lambda: "robot/rich" in exposing_bridge.exposer.nodes, 20, "robot/rich exposed by A")
    wait_for(lambda: "twin/rich" in exposing_bridge.server.nodes, 20, "/twin/rich mirrored by A")
    dp = make_participant(domain_id, localhost=True)
    other = Bridge(dp, None, BridgeOptions(expose=("*",), resync=0)).start()
    try:
        # B's discovery wait (up to 3 s), then its ROS 2 graph is known (START_WINDOW after its
        # first look: it exposes nothing before), then a few looks at both graphs
        wait_for(lambda: other.mirror.knows_graph(time.monotonic()), 15, "B knowing the ROS 2 graph")
        time.sleep(3 * POLL)
        assert other.server.nodes == {}  # nothing mirrored twice, nothing mirrored back
        assert other.exposer.nodes == {}  # robot/rich is a ROS 2 node already (A's); twin/rich is a mirror
    finally:
        other.close()
        close_participant(dp)
