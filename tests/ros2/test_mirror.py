"""The bridge mirrors real rclpy nodes (in subprocesses) on paramdds."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from paramdds.core.values import ParameterType, ParameterValue
from paramdds.dds.client import ParameterClient
from paramdds.dds.monitor import ParameterMonitor
from paramdds.dds.participant import close_participant, make_participant
from paramdds.errors import ErrorCode, OutcomeUnknownError
from paramdds.ros2.mirror import RESYNC_SPREAD, START_WINDOW, next_resync

from .conftest import REALWORLD, SHORT_LEASE, RosHost, oracle, paramdds_cli

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]


@pytest.fixture
def paramdds_side(domain_id: int) -> Iterator[tuple[ParameterClient, ParameterMonitor]]:
    """A paramdds client and monitor of their own (a process that only speaks paramdds)."""
    dp = make_participant(domain_id, localhost=True)
    client = ParameterClient(dp, timeout=10.0)
    monitor = ParameterMonitor(dp)
    yield client, monitor
    monitor.close()
    client.close()
    close_participant(dp)


def wait_for(check: Any, timeout: float, what: str) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = check()
        if got:
            return got
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


def raw(value: ParameterValue) -> dict[str, Any]:
    """A core value in the oracle's raw shape."""
    if value.type is ParameterType.NOT_SET:
        return {"type": 0}
    v = value.value
    return {"type": int(value.type), "value": list(v) if isinstance(v, (tuple, bytes)) else v}


def raw_descriptor(d: Any) -> dict[str, Any]:
    ir, fr = d.integer_range, d.floating_point_range
    return {
        "type": int(d.type),
        "description": d.description,
        "additional_constraints": d.additional_constraints,
        "read_only": d.read_only,
        "dynamic_typing": d.dynamic_typing,
        "integer_range": [] if ir is None else [[ir.from_value, ir.to_value, ir.step]],
        "floating_point_range": [] if fr is None else [[fr.from_value, fr.to_value, fr.step]],
    }


def mirrored(monitor: ParameterMonitor, fqn: str) -> dict[str, Any] | None:
    st = monitor.snapshot().get(fqn.lstrip("/"))
    if st is None or not st.online or not st.complete:
        return None
    return {n: {"value": raw(v), "descriptor": raw_descriptor(d)} for n, (v, d) in st.parameters.items()}


def test_mirrored_state_equals_the_rclpy_nodes_for_the_realworld_files(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any
) -> None:
    if REALWORLD is None:
        pytest.skip("the real parameter files (shared/realworld) are not beside this checkout")
    # the parameter files (the others are generate_parameter_library specs, not for rcl)
    files = sorted(str(p) for p in REALWORLD.glob("*.yaml") if "ros__parameters" in p.read_text())
    assert len(files) >= 5
    args = [a for f in files for a in ("--params-file", f)]
    host: RosHost = ros_hosts(*args, "--rich", "/robot/rich", "--threads", "2")
    assert len(host.nodes) >= 30
    truth = oracle(ros_env, "dump", *host.nodes)
    _, monitor = paramdds_side
    wait_for(lambda: all(mirrored(monitor, n) is not None for n in host.nodes), 60, "every node mirrored")
    for fqn in host.nodes:
        assert mirrored(monitor, fqn) == truth[fqn], fqn
    # every kind of descriptor field came through (the rich node has them all)
    rich = truth["/robot/rich"]
    assert rich["limits.count"]["descriptor"]["integer_range"] == [[0, 10, 2]]
    assert rich["frozen"]["descriptor"]["read_only"] is True
    assert rich["anything"]["descriptor"]["dynamic_typing"] is True
    states = monitor.snapshot()
    assert all(states[n.lstrip("/")].origin == "ros2" for n in host.nodes)


def test_paramdds_set_changes_the_rclpy_node_with_refusals_per_parameter(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any
) -> None:
    host: RosHost = ros_hosts("--rich", "/robot/rich")
    client, _ = paramdds_side
    client.wait_for_node("robot/rich", timeout=30)

    def clients() -> set[str]:  # the bridge's ROS 2 clients of this node's services
        return {
            c.srv_name
            for c in bridge.ros.node.clients
            if c.srv_name.startswith("/robot/rich/")
            and c.srv_name != "/robot/rich/get_parameter_types"  # its process's probe (.liveness)
        }

    # read clients live only while the bridge reads the node: every idle one costs each
    # wake-up of rclpy's executor (see RosLink._reads)
    wait_for(lambda: not clients(), 10, "the read clients destroyed once the node is read")
    out = paramdds_cli(
        ros_env,
        "set",
        "/robot/rich",
        "mode=bad",
        "limits.speed=2",  # an integer: widened to a double, as paramdds does (rclpy would refuse it)
        "limits.count=3",
        "frozen=x",
        "nope=1",
        "-o",
        "json",
    )
    assert out.returncode == 1, out.stderr
    results = json.loads(out.stdout)
    assert results["limits.speed"]["successful"] is True
    assert not any(results[n]["successful"] for n in ("mode", "limits.count", "frozen", "nope"))
    assert "mode must be auto or manual" in results["mode"]["reason"]  # the node's own reason
    assert "read-only" in results["frozen"]["reason"]
    assert host.command("get /robot/rich limits.speed") == "value 2.0"
    # the codes, per parameter, mapped from ROS 2's reasons
    reply = client.set("robot/rich", {"mode": "bad", "limits.count": 3, "frozen": "x", "nope": 1, "ids": [4]})
    codes = {r.name: r.code for r in reply.results}
    assert codes == {
        "mode": ErrorCode.INVALID_VALUE,
        "limits.count": ErrorCode.OUT_OF_RANGE,
        "frozen": ErrorCode.READ_ONLY,
        "nope": ErrorCode.NOT_FOUND,
        "ids": None,
    }
    assert host.command("get /robot/rich ids") == "value [4]"
    assert clients() == {"/robot/rich/set_parameters"}  # kept: sets come again
    assert client.get("robot/rich", ["limits.speed"]).values()["limits.speed"] == ParameterValue.from_python(
        2.0
    )

    # atomic: nothing applied, every parameter says why
    atomic = client.set("robot/rich", {"limits.speed": 3.0, "mode": "bad"}, atomic=True)
    assert not any(r.successful for r in atomic.results)
    assert host.command("get /robot/rich limits.speed") == "value 2.0"
    # compare-and-set is refused clearly, and changes nothing
    out = paramdds_cli(ros_env, "set", "/robot/rich", "limits.speed=4.0", "--if-revision", "1")
    assert out.returncode == 1 and "compare-and-set is not available" in out.stderr
    # delete a dynamically typed parameter: gone from the rclpy node and the mirror
    deleted = client.delete("robot/rich", ["anything"])
    assert all(r.successful for r in deleted.results)
    assert client.get("robot/rich", ["anything"]).missing()[0].code is ErrorCode.NOT_FOUND
    listed = oracle(ros_env, "dump", "/robot/rich")["/robot/rich"]
    assert "anything" not in listed and listed["limits.speed"]["value"] == {"type": 3, "value": 2.0}


def test_a_change_made_in_rclpy_reaches_paramdds_watch(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any
) -> None:
    host: RosHost = ros_hosts("--rich", "/robot/rich")
    client, _ = paramdds_side
    client.wait_for_node("robot/rich", timeout=30)
    watch = subprocess.Popen(
        [sys.executable, "-m", "paramdds.cli", "watch", "robot/rich"],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(watch.stdout or []), daemon=True)
    try:
        reader.start()
        wait_for(lambda: any("limits.speed" in line for line in lines), 20, "the watch's initial state")
        assert host.command("set /robot/rich limits.speed 4.25") == "set ok"
        wait_for(lambda: any("4.25" in line for line in lines), 20, "the change in the watch")
    finally:
        watch.terminate()
        watch.wait(timeout=10)
        reader.join(timeout=5)
        if watch.stdout is not None:
            watch.stdout.close()


def test_a_node_killed_and_restarted_goes_offline_and_comes_back_resynced(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any, tmp_path: Any, domain_id: int
) -> None:
    first = tmp_path / "first.yaml"
    first.write_text("/arm/driver:\n  ros__parameters:\n    gain: 1.0\n    port: /dev/a\n")
    second = tmp_path / "second.yaml"
    second.write_text("/arm/driver:\n  ros__parameters:\n    gain: 2.0\n    baud: 9600\n")
    client, monitor = paramdds_side
    # what `paramdds watch` shows of the node: (event, revision, incarnation)
    events: list[tuple[str, int, int]] = []
    watcher_dp = make_participant(domain_id, localhost=True)
    watcher = ParameterMonitor(
        watcher_dp,
        on_event=lambda e: (
            events.append((e.event.value, e.revision, e.incarnation)) if e.node == "arm/driver" else None
        ),
    )
    host: RosHost = ros_hosts("--params-file", str(first))
    client.wait_for_node("arm/driver", timeout=30)

    def values() -> dict[str, Any] | None:
        st = monitor.snapshot().get("arm/driver")
        return {n: v.value for n, (v, _) in st.parameters.items()} if st and st.online else None

    wait_for(lambda: (values() or {}).get("gain") == 1.0, 10, "the first values")
    first_hosting = monitor.snapshot()["arm/driver"]
    host.close()  # a clean shutdown: the node leaves the graph at once
    wait_for(lambda: monitor.snapshot()["arm/driver"].online is False, 10, "offline after a clean stop")

    # a restart with other parameters comes back with exactly those
    host = ros_hosts("--params-file", str(second))
    expected = {"gain": 2.0, "baud": 9600, "use_sim_time": False, "start_type_description_service": True}
    try:
        wait_for(lambda: values() == expected, 20, "resynced after a restart")
    except AssertionError:
        raise AssertionError(f"{values()} != {expected}") from None

    # the watch is another monitor: it may show that restart later than ours (CI: its events came
    # after the mark below, and its 'online' was taken for the one after the kill)
    second = monitor.snapshot()["arm/driver"].incarnation
    wait_for(
        lambda: ("online", second) in [(k, i) for k, _, i in events], 10, "the restart online in the watch"
    )

    # kill -9 and restart at once: the dead participant stays in the ROS 2 graph for
    # Fast DDS's lease, but the new /parameter_events writer says it restarted
    before = len(events)
    host.kill()
    host = ros_hosts("--params-file", str(first))
    wait_for(
        lambda: (values() or {}).get("gain") == 1.0 and "baud" not in (values() or {}),
        20,
        "resynced after kill -9 and restart",
    )
    # its revisions start again, as a restarted native node's: those of its first hosting (the
    # same file), under a new incarnation; and the watch shows it offline, then online
    again = monitor.snapshot()["arm/driver"]
    assert again.revision == first_hosting.revision and again.incarnation != first_hosting.incarnation
    wait_for(lambda: "online" in [e for e, _, _ in events[before:]], 10, "online in the watch")
    kinds = [e for e, _, _ in events[before:]]
    assert "offline" in kinds and kinds.index("offline") < kinds.index("online"), events[before:]
    watcher.close()
    close_participant(watcher_dp)


def test_a_tool_node_living_under_a_second_is_not_mirrored(
    ros_hosts: Any, bridge: Any, paramdds_side: Any
) -> None:
    """Nodes like the one `ros2 param` makes for a moment are not mirrored (docs/ros2.md); a
    node that stays for a few seconds is (the control)."""
    client, monitor = paramdds_side
    host: RosHost = ros_hosts("--node", "/tools/host")
    client.wait_for_node("tools/host", timeout=30)
    time.sleep(START_WINDOW)  # past the bridge's first looks, whose nodes are mirrored at once
    seen: set[str] = set()
    for i in range(3):  # each its own name, as each `ros2 param` run's node
        # long enough to be read and mirrored (a bridge without the rule does), under MIN_AGE
        assert host.command(f"blink /tools/brief{i} 1.2") == "blinked"
        seen |= set(monitor.snapshot())
    time.sleep(2.5)  # a mirror of one would be on paramdds by now
    assert not {n for n in seen | set(monitor.snapshot()) if n.startswith("tools/brief")}
    assert host.command("blink /tools/lasting 5.0") == "blinked"
    assert "tools/lasting" in monitor.snapshot()


def test_a_hanging_callback_delays_only_its_node(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any
) -> None:
    ros_hosts("--hang", "/hanger", "--rich", "/robot/rich")
    client, _ = paramdds_side
    client.wait_for_node("hanger", timeout=30)
    client.wait_for_node("robot/rich", timeout=30)
    outcome: dict[str, Any] = {}

    def hang() -> None:
        started = time.monotonic()
        try:
            outcome["reply"] = client.set("hanger", {"hang": 1}, timeout=3.0)
        except OutcomeUnknownError as exc:  # the bridge gave up on the ROS 2 node: it may apply it
            outcome["error"] = exc
        outcome["took"] = time.monotonic() - started

    thread = threading.Thread(target=hang)
    thread.start()
    time.sleep(0.3)
    started = time.monotonic()
    reply = client.set("robot/rich", {"limits.speed": 3.5})
    assert reply.results[0].successful
    assert time.monotonic() - started < 1.5  # not behind the hanging node
    thread.join(timeout=15)
    assert outcome["took"] < 6.0  # bounded by the caller's 3 s (the bridge waits until its deadline)
    # never a per-parameter TIMEOUT (a "failure" the ROS 2 node may still apply): unknown
    assert "reply" not in outcome, outcome
    assert "outcome unknown" in str(outcome["error"]) and "/hanger" in str(outcome["error"])
    # once the bridge gave up on the call, the node is online again and answers
    client.wait_for_node("hanger", timeout=10)
    assert client.get("hanger", ["hang"]).values()["hang"] == ParameterValue.from_python(0)


def test_a_killed_node_goes_offline_within_the_lease_its_process_announced(
    ros_env: dict[str, str], bridge: Any, paramdds_side: Any, tmp_path: Any
) -> None:
    """docs/ros2.md: a Fast DDS profile with a 3 s lease in the ROS 2 process (not the bridge)
    makes a kill -9 show offline within about that, instead of the default 20 s."""
    profile = tmp_path / "short_lease.xml"
    profile.write_text(SHORT_LEASE)
    host = RosHost({**ros_env, "FASTDDS_DEFAULT_PROFILES_FILE": str(profile)}, "--node", "/arm/brief")
    client, monitor = paramdds_side
    try:
        client.wait_for_node("arm/brief", timeout=30)
        killed = time.monotonic()
        host.kill()
        wait_for(lambda: monitor.snapshot()["arm/brief"].online is False, 10, "offline after the lease")
        assert time.monotonic() - killed < 8.0  # 3 s lease, the bridge's 0.5 s look, margin for load
    finally:
        host.close()


def test_the_cli_verb_bridges_and_nodes_shows_the_origin(ros_env: dict[str, str], ros_hosts: Any) -> None:
    ros_hosts("--rich", "/robot/rich")
    bridge = subprocess.Popen(
        [sys.executable, "-m", "paramdds.cli", "ros2", "--exclude", "/other/*"],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert bridge.stdout is not None
        banner = bridge.stdout.readline()
        assert (
            f"ROS 2 domain {ros_env['ROS_DOMAIN_ID']} and paramdds domain {ros_env['PARAMDDS_DOMAIN']}"
            in banner
        )
        got = paramdds_cli(ros_env, "get", "/robot/rich", "mode", "-o", "json")
        assert got.returncode == 0, got.stderr
        assert json.loads(got.stdout) == {"mode": "auto"}
        nodes = json.loads(paramdds_cli(ros_env, "nodes", "-o", "json").stdout)
        assert [(n["node"], n["origin"]) for n in nodes] == [("/robot/rich", "ros2")]  # shown with its slash
    finally:
        bridge.send_signal(signal.SIGINT)
        _, err = bridge.communicate(timeout=30)
    assert bridge.returncode == 130, err


def test_the_periodic_resync_repairs_a_mirror_that_missed_a_change(
    ros_env: dict[str, str], ros_hosts: Any, domain_id: int, paramdds_side: Any
) -> None:
    from paramdds.ros2.bridge import Bridge, BridgeOptions

    ros_hosts("--rich", "/robot/rich")
    dp = make_participant(domain_id, localhost=True)
    bridge = Bridge(dp, None, BridgeOptions(timeout=2.0, resync=1.0)).start()
    try:
        client, _ = paramdds_side
        client.wait_for_node("robot/rich", timeout=30)
        mirrored = wait_for(lambda: bridge.mirror.nodes.get("/robot/rich"), 10, "the mirror")
        # as if a /parameter_events sample had been lost: the mirror holds a stale value
        value, desc = mirrored.table.snapshot()[[n for n, *_ in mirrored.table.snapshot()].index("mode")][1:]
        mirrored.table.mirror({"mode": (ParameterValue.from_python("stale"), desc)})
        assert client.get("robot/rich", ["mode"]).values()["mode"] == ParameterValue.from_python("stale")
        wait_for(
            lambda: client.get("robot/rich", ["mode"]).values()["mode"] == value, 10, "the resync's repair"
        )
    finally:
        bridge.close()
        close_participant(dp)


def test_the_nodes_read_at_the_same_instant_resync_at_different_times() -> None:
    """300 mirrors read together at a bridge's start: their periodic resyncs are due over the
    last quarter of the period, not all at its end (each sync draws the next one)."""
    due = [next_resync(100.0, 60.0) for _ in range(300)]
    assert all(100.0 + 60.0 * (1 - RESYNC_SPREAD) <= d <= 160.0 for d in due)
    assert max(due) - min(due) > 60.0 * RESYNC_SPREAD * 0.8  # spread over most of the window


def test_a_dump_piped_into_load_onto_a_mirrored_rclpy_node_is_a_no_op(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any, domain_id: int
) -> None:
    """`paramdds dump NODE | paramdds load NODE` (read-only parameters and descriptors included)
    changes nothing: exit 0, the same revision, no change event."""
    ros_hosts("--rich", "/robot/rich")
    client, monitor = paramdds_side
    client.wait_for_node("robot/rich", timeout=30)
    dp = make_participant(domain_id, localhost=True)
    changes: list[Any] = []
    watcher = ParameterMonitor(
        dp,
        on_event=lambda e: changes.append(e) if e.event.value in ("added", "modified", "deleted") else None,
    )
    try:
        assert watcher.wait_synced(timeout=10)
        changes.clear()  # the initial state
        before = monitor.snapshot()["robot/rich"]
        cli = f"{sys.executable} -m paramdds.cli"
        piped = subprocess.run(
            ["bash", "-o", "pipefail", "-c", f"{cli} dump /robot/rich | {cli} load /robot/rich /dev/stdin"],
            env=ros_env,
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert piped.returncode == 0, piped.stdout + piped.stderr
        lines = piped.stdout.splitlines()
        # every parameter was loaded and found unchanged, read-only ones included
        assert {line.split(":")[0] for line in lines[:-1]} == set(before.parameters), lines
        assert all(line.endswith(": unchanged") for line in lines[:-1]), lines
        time.sleep(1.0)  # a change would have reached the monitors by now
        after = monitor.snapshot()["robot/rich"]
        assert changes == [] and after.revision == before.revision, (changes, before.revision, after.revision)
        assert after.parameters == before.parameters
    finally:
        watcher.close()
        close_participant(dp)


def test_the_bridge_side_knows_the_type_of_every_endpoint_a_plain_node_has(ros_env: dict[str, str]) -> None:
    """Fast DDS 3.2 can crash (SIGSEGV) in XTypes type lookup when many endpoints of a type it
    does not know are discovered at once (issue 30: the /rosout writers of 100 nodes, a bridge
    start in about 1 of 10 under CPU starvation). The bridge's side makes an endpoint of every
    type a plain rclpy node (use_sim_time on) has an endpoint of, so Fast DDS never looks one up."""
    import rclpy
    from rclpy.parameter import Parameter

    from paramdds.ros2.rosside import RosSide

    side = RosSide(None, "paramdds_types_probe")
    plain = rclpy.create_node(
        "paramdds_plain_probe",
        context=side.context,
        parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)],
    )
    try:

        def types(node: Any, *queries: str) -> set[str]:
            name, ns = node.get_name(), node.get_namespace()
            return {t for q in queries for _, ts in getattr(node, q)(name, ns) for t in ts}

        endpoints = ("get_publisher_names_and_types_by_node", "get_subscriber_names_and_types_by_node")
        services = ("get_service_names_and_types_by_node", "get_client_names_and_types_by_node")
        known = types(side.node, *endpoints, *services)
        needed = types(plain, *endpoints, *services)
        assert {"rcl_interfaces/msg/Log", "rosgraph_msgs/msg/Clock"} <= needed  # what the probe covers
        assert needed <= known, needed - known
    finally:
        plain.destroy_node()
        side.close()
