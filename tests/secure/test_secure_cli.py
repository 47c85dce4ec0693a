"""Secure mode end to end: real secure Cyclone, real processes, one keystore (see conftest)."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from .conftest import SecureSystem, stop, wait_line

pytestmark = pytest.mark.slow


def test_full_rights_identity_runs_the_ordinary_flows(system: SecureSystem) -> None:
    assert {"robot1", "robot2"} <= set(system.nodes("admin", {"robot1", "robot2"}))
    listed = system.run("admin", "list", "robot1")
    assert listed.stdout.split() == ["robot.max_velocity", "robot.mode", "robot.name", "robot.wheel_count"]
    done = system.run("admin", "set", "robot2", "robot.wheel_count=6")
    assert done.returncode == 0, done.stderr
    got = system.run("admin", "get", "robot2", "robot.wheel_count", "robot.name")
    assert got.stdout.splitlines() == ["robot.wheel_count = integer 6", "robot.name = string 'my_robot'"]
    described = system.run("admin", "describe", "robot2", "robot.wheel_count")
    assert described.returncode == 0 and "integer" in described.stdout, described
    dumped = system.run("admin", "dump", "robot2", "--no-descriptors")
    assert "wheel_count: 6" in dumped.stdout, dumped.stdout
    watch = system.start("admin", "watch", "robot2", "-o", "json")
    try:
        wait_line(watch, '"synced"')
        assert system.run("admin", "set", "robot2", "robot.mode=moving").returncode == 0
        wait_line(watch, '"moving"', timeout=10)
    finally:
        stop(watch)


def test_viewer_watches_and_gets_but_every_set_fails(system: SecureSystem) -> None:
    got = system.run("viewer", "get", "robot1", "robot.max_velocity")
    assert got.returncode == 0, got.stderr
    assert got.stdout.strip() == "robot.max_velocity = double 1.5"
    assert {"robot1", "robot2"} <= set(system.nodes("viewer", {"robot1", "robot2"}))  # a monitor, as watch
    for args in (["set", "robot1", "robot.max_velocity=2.5"], ["delete", "robot1", "robot.name"]):
        refused = system.run("viewer", *args)
        assert refused.returncode == 1, refused
        assert "not permitted for identity 'viewer'" in refused.stderr
        assert "NOT_ALLOWED_BY_SECURITY" in refused.stderr
    assert system.value("robot1", "robot.max_velocity") == 1.5


def test_operator_granted_robot1_star_sets_robot1_never_robot2(system: SecureSystem) -> None:
    done = system.run("op1", "set", "robot1", "robot.mode=op1")
    assert done.returncode == 0, done.stderr
    assert system.value("robot1", "robot.mode") == "op1"
    refused = system.run("op1", "set", "robot2", "robot.mode=op1")
    assert refused.returncode == 1
    assert "set on node 'robot2': not permitted for identity 'op1'" in refused.stderr
    assert system.value("robot2", "robot.mode") != "op1"


def test_no_certificate_or_a_foreign_ca_sees_nothing_and_changes_nothing(
    system: SecureSystem, foreign_keystore: Path
) -> None:
    for identity, keystore in ((None, None), ("admin", foreign_keystore)):
        nodes = system.run(identity, "nodes", keystore=keystore)
        assert "robot1" not in nodes.stdout, (identity, nodes.stdout)
        got = system.run(identity, "get", "robot1", "robot.name", "--timeout", "2", keystore=keystore)
        assert got.returncode == 3, (identity, got)
        assert "my_robot" not in got.stdout
        sent = system.run(
            identity, "set", "robot1", "robot.name=intruder", "--timeout", "2", keystore=keystore
        )
        assert sent.returncode == 3, (identity, sent)
    time.sleep(0.5)
    assert system.value("robot1", "robot.name") == "my_robot"


def test_a_server_granted_robot1_cannot_serve_robot2(system: SecureSystem) -> None:
    done = system.run("srv1", "server", "-n", "robot2", "-p", str(system.params), timeout=30)
    assert done.returncode == 1, done
    assert "serving nodes ['robot2']: not permitted for identity 'srv1'" in done.stderr


ROGUE = """
import sys, time
from paramdds.dds.participant import make_participant, close_participant
from paramdds.secure.identity import load_identity
from paramdds.dds.wire import types as wire
from cyclonedds.pub import DataWriter
from paramdds.dds.topics import make_topic
from paramdds.dds.qos import QosProfiles

dp = make_participant(int(sys.argv[2]), localhost=True, identity=load_identity(sys.argv[1]))
qos = QosProfiles.load()
# robot1 is granted: a writer in its partition is allowed, and it names other nodes
topic = make_topic(dp, "ParameterEvents", wire.ParameterEvent)
writer = DataWriter(dp.transport.publisher(["robot1"]), topic, qos.writer("ParameterEvents"))
value = wire.ParameterValue(type=4, string_value="rogue-value")
for _ in range(20):
    writer.write(wire.ParameterEvent(node_id="robot2", name="robot.name", kind=wire.EVENT_PARAMETER,
                                     revision=99, value=value))
    writer.write(wire.ParameterEvent(node_id="ghost", name="", kind=wire.EVENT_PRESENCE, revision=1,
                                     host="rogue", pid=1, parameter_count=0))
    writer.write(wire.ParameterEvent(node_id="robot2", name="", kind=wire.EVENT_PRESENCE, revision=99,
                                     host="rogue", pid=1, parameter_count=1))
    time.sleep(0.1)
print("written", flush=True)
time.sleep(float(sys.argv[3]))
close_participant(dp)
"""


def test_state_a_granted_writer_writes_for_another_node_is_ignored(system: SecureSystem) -> None:
    watch = system.start("admin", "watch", "-o", "json")
    rogue = subprocess.Popen(
        [str(system.bin / "python"), "-c", ROGUE, system.identity("srv1"), str(system.domain), "8"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=system.env(),
    )
    try:
        wait_line(rogue, "written")
        listed = system.nodes("admin", {"robot1", "robot2"})  # a late joiner: gets the rogue's state too
        assert "ghost" not in listed
        assert listed["robot2"]["host"] != "rogue"
        got = system.run("admin", "get", "robot2", "robot.name")  # a client: presence and reply
        assert got.stdout.strip() == "robot.name = string 'my_robot'", got
        absent = system.run("admin", "get", "ghost", "x", "--timeout", "3")
        assert absent.returncode == 3
        assert "is not present" in absent.stderr, absent.stderr
    finally:
        out, _ = stop(watch)
        stop(rogue)
    assert "rogue-value" not in out and '"ghost"' not in out
    assert '"node": "robot2"' in out  # the monitor did see robot2's real state


def test_parameter_values_never_appear_in_plain_text_on_the_wire(
    system: SecureSystem, tmp_path: Path
) -> None:
    marker = "secret-marker-7fq2"
    capture = tmp_path / "lo.pcap"

    def captured(identity: str | None, node: str, env_domain: SecureSystem) -> bytes:
        base = 7400 + 250 * env_domain.domain  # Cyclone's ports of this domain (others share lo)
        dump = subprocess.Popen(
            ["tcpdump", "-i", "lo", "-U", "-w", str(capture), "udp", "portrange", f"{base}-{base + 249}"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        time.sleep(1.0)
        try:
            done = env_domain.run(identity, "set", node, f"robot.name={marker}")
            assert done.returncode == 0, done.stderr
            assert env_domain.run(identity, "get", node, "robot.name").returncode == 0
            time.sleep(0.5)
        finally:
            dump.terminate()
            dump.wait(timeout=10)
        return capture.read_bytes()

    secure = captured("admin", "robot1", system)
    assert len(secure) > 10_000  # the capture did record the traffic
    assert marker.encode() not in secure
    assert b"robot.name" not in secure and b"robot.max_velocity" not in secure
    # the control: the same flow without security shows the value, so the check can fail
    plain = SecureSystem(
        system.bin, system.keystore, system.domain + 1 if system.domain < 230 else 100, system.params
    )
    server = plain.start(None, "server", "-n", "plain1", "-p", str(system.params))
    try:
        wait_line(server, "[SERVER] Serving")
        assert marker.encode() in captured(None, "plain1", plain)
    finally:
        stop(server)


ROGUE_REQUEST = """
import sys, time
from paramdds.dds.participant import make_participant, close_participant
from paramdds.secure.identity import load_identity
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.convert import parameter_to_wire
from paramdds.core.values import Parameter, ParameterValue

dp = make_participant(int(sys.argv[2]), localhost=True, identity=load_identity(sys.argv[1]))
writer = dp.transport.writer("SetParametersRequest", "robot3", None)  # granted: robot3
for request_id, node in enumerate(["robot4", "robot3"] * 10, start=1):
    param = parameter_to_wire(Parameter("robot.mode", ParameterValue.from_python("via-robot3")))
    request = wire.SetParametersRequest(node_id=node, client_id=7, request_id=request_id, parameters=[param])
    writer.write(request)
    time.sleep(0.1)
time.sleep(0.5)
close_participant(dp)
"""


def test_a_request_naming_a_node_outside_its_writers_partitions_is_not_applied(system: SecureSystem) -> None:
    server = system.start("srv34", "server", "-n", "robot3", "-n", "robot4", "-p", str(system.params))
    try:
        wait_line(server, "[SERVER] Serving")
        done = subprocess.run(
            [str(system.bin / "python"), "-c", ROGUE_REQUEST, system.identity("op3"), str(system.domain)],
            capture_output=True,
            text=True,
            timeout=60,
            env=system.env(),
            check=False,
        )
        assert done.returncode == 0, done.stderr
        # the same writer's requests for robot3 (its partition) reach this server and are applied ...
        assert system.value("robot3", "robot.mode") == "via-robot3"
        # ... while those naming robot4, also hosted here, are dropped
        assert system.value("robot4", "robot.mode") == "idle"
    finally:
        _, err = stop(server)
    assert "Traceback" not in err, err


def test_the_web_console_serves_as_its_identity(system: SecureSystem) -> None:
    """``paramdds web --identity``: the console of an operator granted ``robot1*`` reads and
    sets robot1; robot2, outside its grants, is not even visible to it."""
    import socket

    import httpx

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    url = f"http://127.0.0.1:{port}/api/"
    console = system.start("op1", "web", "--bind", f"127.0.0.1:{port}", "--timeout", "5")
    try:
        wait_line(console, "[WEB] Console on")
        deadline = time.monotonic() + 20
        while "robot1" not in {n["node"] for n in httpx.get(url + "nodes", timeout=5).json()["nodes"]}:
            assert time.monotonic() < deadline, "robot1 never reached the console"
            time.sleep(0.1)
        done = httpx.post(url + "set", json={"node": "robot1", "values": {"robot.mode": "web"}}, timeout=15)
        assert done.status_code == 200, done.text
        assert system.value("robot1", "robot.mode") == "web"
        # robot2's partition is not granted to op1: the console never sees it
        assert "robot2" not in {n["node"] for n in httpx.get(url + "nodes", timeout=5).json()["nodes"]}
        body = {"node": "robot2", "values": {"robot.mode": "web"}}
        refused = httpx.post(url + "set", json=body, timeout=15)
        assert (refused.status_code, refused.json()["error"]["code"]) == (404, "NOT_FOUND"), refused.text
        assert system.value("robot2", "robot.mode") != "web"
    finally:
        _, err = stop(console)
    assert "Traceback" not in err, err
