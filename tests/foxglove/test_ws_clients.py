"""``paramdds foxglove`` against a real Foxglove client: @foxglove/ws-protocol's FoxgloveClient.

Real processes on the test's own domain: two ``paramdds server`` processes hosting three
nodes (``arm`` and ``base`` in one, ``cam`` in the other, so one node can be killed), a
``paramdds foxglove`` server on a free port, and the Node scripts of ``node/`` as clients,
each connecting with the client's own subprotocol (``foxglove.websocket.v1``, what Lichtblick
asks for) and again with ``foxglove.sdk.v1``.
"""

from __future__ import annotations

import base64
import json
import re
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .conftest import run_node, start_node

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]
READY = re.compile(r"^\[FOXGLOVE\] Foxglove WebSocket server on (ws://\S+) \((\d+) nodes?\)$")

PARAMS = """\
/**:
  ros__parameters:
    speed: 1.5
    gain: 2.0
    count: 4
    name: "my_robot"
    enabled: true
    weights: !double_array [0.5, 1.0]
    ids: [1, 2, 3]
    frames: ["base", "laser"]
    flags: [true, false]
    blob: !byte_array [1, 2, 255]
    fixed: 7
  paramdds__descriptors:
    speed:
      type: double
      floating_point_range: [0.0, 5.0, 0.0]
    fixed:
      type: integer
      read_only: true
"""
# Every parameter of one node as the protocol carries it: (value, type hint or None).
EXPECTED: dict[str, tuple[Any, str | None]] = {
    "speed": (1.5, "float64"),
    "gain": (2.0, "float64"),
    "count": (4, None),
    "name": ("my_robot", None),
    "enabled": (True, None),
    "weights": ([0.5, 1.0], "float64_array"),
    "ids": ([1, 2, 3], None),
    "frames": (["base", "laser"], None),
    "flags": ([True, False], None),
    "blob": (base64.b64encode(bytes([1, 2, 255])).decode(), "byte_array"),
    "fixed": (7, None),
}
NODES = ("arm", "base", "cam")


class Fleet:
    """Three nodes in two server processes, and the Foxglove server in front of them."""

    def __init__(self, domain: int, tmp: Path) -> None:
        self.domain = domain
        self.env = make_dds_env(domain)
        self.params = tmp / "params.yaml"
        self.params.write_text(PARAMS)
        self.procs: list[Proc] = []

    def start(self, *foxglove_args: str) -> None:
        self.arm_base = self._start_server("arm", "base")
        self.cam = self._start_server("cam")
        argv = [PARAMDDS, "foxglove", "-d", str(self.domain), "--port", "0", *foxglove_args]
        self.foxglove = Proc(argv, self.env)
        self.procs.append(self.foxglove)
        _, line = self.foxglove.wait_for(lambda line: READY.match(line) is not None, 30)
        match = READY.match(line)
        assert match is not None
        self.url, self.nodes_at_start = match.group(1), int(match.group(2))
        assert self.url.startswith("ws://127.0.0.1:"), line

    def _start_server(self, *nodes: str) -> Proc:
        argv = [PARAMDDS, "server", "-p", str(self.params)]
        for node in nodes:
            argv += ["-n", node]
        proc = Proc(argv, self.env)
        self.procs.append(proc)
        for node in nodes:
            proc.wait_for(f"Serving node {node} ", 20)
        return proc

    def restart_cam(self) -> None:
        self.cam = self._start_server("cam")

    def cli(self, *args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [PARAMDDS, *args], env=self.env, capture_output=True, text=True, timeout=30, check=False
        )

    def node_value(self, node: str, name: str) -> Any:
        """A parameter's value as the node holds it, read by the CLI (``get -o json``)."""
        done = self.cli("get", node, name, "-o", "json")
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)[name]

    def stop(self) -> None:
        """Stop everything; the Foxglove server must have exited 0 on SIGTERM, without a traceback."""
        codes = {id(proc): proc.stop() for proc in reversed(self.procs)}
        if hasattr(self, "foxglove"):
            stderr = self.foxglove.stderr_text()
            assert codes[id(self.foxglove)] == 0 and "Traceback" not in stderr, (
                codes[id(self.foxglove)],
                stderr,
            )


@pytest.fixture
def fleet(domain_id: int, tmp_path: Path, node_dir: Path) -> Iterator[Fleet]:
    fleet = Fleet(domain_id, tmp_path)
    try:
        fleet.start()
        yield fleet
    finally:
        fleet.stop()


def by_name(message: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """A parameterValues message's parameters by name."""
    return {p["name"]: p for p in message["parameters"]}


def as_pair(parameter: dict[str, Any]) -> tuple[Any, str | None]:
    return parameter.get("value"), parameter.get("type")


def exact(value: Any) -> Any:
    """``value`` with its JSON number kinds kept apart (1 and 1.0 differ), for exact comparison."""
    if isinstance(value, list):
        return [exact(v) for v in value]
    return (type(value).__name__ if isinstance(value, (int, float)) else "", value)


def event(events: list[dict[str, Any]], name: str) -> dict[str, Any]:
    found = [e for e in events if e["event"] == name]
    assert len(found) == 1, f"one {name!r} event expected: {events!r}"
    return found[0]


def json_event(line: str) -> dict[str, Any]:
    parsed: dict[str, Any] = json.loads(line)
    return parsed


def waits_for_event(
    proc: Proc, name: str, test: Any = None, timeout: float = 15.0
) -> tuple[float, dict[str, Any]]:
    """The next line of a running script that is event ``name`` (and passes ``test``), and when it came."""

    def matches(line: str) -> bool:
        item = json_event(line)
        if item["event"] in ("error", "timeout"):
            raise AssertionError(f"the client ended: {item!r}; stderr {proc.stderr_text()!r}")
        return bool(item["event"] == name and (test is None or test(item)))

    at, line = proc.wait_for(matches, timeout)
    return at, json_event(line)


def assert_server_alive(fleet: Fleet) -> None:
    assert fleet.foxglove.popen.poll() is None, fleet.foxglove.stderr_text()
    assert "Traceback" not in fleet.foxglove.stderr_text(), fleet.foxglove.stderr_text()


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_server_info_names_the_parameter_capabilities(fleet: Fleet, subprotocol: str) -> None:
    assert fleet.nodes_at_start == len(NODES)
    info = event(run_node("info.js", fleet.url, subprotocol), "serverInfo")
    assert info["protocol"] == subprotocol
    assert {"parameters", "parametersSubscribe"} <= set(info["info"]["capabilities"])


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_get_all_returns_every_parameter_of_every_node_with_exact_types(
    fleet: Fleet, subprotocol: str
) -> None:
    reply = event(run_node("get.js", fleet.url, subprotocol), "reply")["message"]
    assert reply["id"] == "get-1"
    got = {name: as_pair(p) for name, p in by_name(reply).items()}
    assert len(got) == len(reply["parameters"]), "a name came twice"
    expected = {f"/{node}.{name}": pair for node in NODES for name, pair in EXPECTED.items()}
    assert got == expected
    # integers stay integers (no type, a JSON integer); doubles carry float64 even when whole
    for name, (value, hint) in expected.items():
        if hint is None:
            assert exact(got[name][0]) == exact(value), name

    some = ["/arm.speed", "/cam.blob", "/base.frames"]
    reply = event(run_node("get.js", fleet.url, subprotocol, *some), "reply")["message"]
    assert {name: as_pair(p) for name, p in by_name(reply).items()} == {name: expected[name] for name in some}


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_set_is_echoed_and_reaches_the_nodes_with_its_types(fleet: Fleet, subprotocol: str) -> None:
    request = [
        {"name": "/arm.speed", "value": 3, "type": "float64"},  # whole, so JavaScript sends 3
        {"name": "/arm.name", "value": "renamed"},
        {"name": "/arm.blob", "value": base64.b64encode(b"\x00\x01\x02").decode(), "type": "byte_array"},
        {"name": "/base.count", "value": 9},
        {"name": "/base.weights", "value": [2, 0.25], "type": "float64_array"},
    ]
    events = run_node("set.js", fleet.url, subprotocol, json.dumps(request))
    reply = event(events, "reply")["message"]
    assert reply["id"] == "set-1"
    expected = {p["name"]: (p["value"], p.get("type")) for p in request}
    assert {name: as_pair(p) for name, p in by_name(reply).items()} == expected
    assert [e for e in events if e["event"] == "status"] == []
    assert {name: as_pair(p) for name, p in by_name(event(events, "after")["message"]).items()} == expected

    assert exact(fleet.node_value("arm", "speed")) == exact(3.0)  # still a double on the node
    assert fleet.node_value("arm", "name") == "renamed"
    assert fleet.node_value("arm", "blob") == [0, 1, 2]
    assert fleet.node_value("base", "count") == 9
    assert exact(fleet.node_value("base", "weights")) == exact([2.0, 0.25])


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_refused_set_answers_the_old_values_and_a_warning_with_the_nodes_reason(
    fleet: Fleet, subprotocol: str
) -> None:
    request = [
        {"name": "/arm.speed", "value": 9.5, "type": "float64"},  # out of [0.0, 5.0]
        {"name": "/arm.count", "value": 5},  # same node: the node's request is refused as a whole
        {"name": "/base.fixed", "value": 8},  # read-only
        {"name": "/cam.name", "value": "accepted"},  # another node: applied
    ]
    events = run_node("set.js", fleet.url, subprotocol, json.dumps(request))
    reply = by_name(event(events, "reply")["message"])
    assert {name: as_pair(p) for name, p in reply.items()} == {
        "/arm.speed": (1.5, "float64"),
        "/arm.count": (4, None),
        "/base.fixed": (7, None),
        "/cam.name": ("accepted", None),
    }
    statuses = [e["message"] for e in events if e["event"] == "status"]
    assert statuses, "a refused set must say why"
    assert all(s["level"] == 1 and s["id"] == "set-1" for s in statuses), statuses
    text = "\n".join(s["message"] for s in statuses)
    assert "must be within [0.0, 5.0]" in text and "read-only" in text, text
    assert fleet.node_value("arm", "speed") == 1.5
    assert fleet.node_value("arm", "count") == 4
    assert fleet.node_value("base", "fixed") == 7
    assert fleet.node_value("cam", "name") == "accepted"


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_subscriber_sees_a_change_made_by_the_cli_within_one_second(fleet: Fleet, subprotocol: str) -> None:
    subscriber = start_node("subscribe.js", fleet.url, subprotocol, "20", "/arm.speed", "/cam.name")
    fleet.procs.append(subscriber)
    _, subscribed = waits_for_event(subscriber, "subscribed")
    assert as_pair(by_name(subscribed["message"])["/arm.speed"]) == (1.5, "float64")

    done = fleet.cli("set", "arm", "speed=2.25")
    acknowledged = time.monotonic()
    assert done.returncode == 0, done.stderr
    at, update = waits_for_event(
        subscriber, "update", lambda e: "/arm.speed" in by_name(e["message"]), timeout=5
    )
    assert as_pair(by_name(update["message"])["/arm.speed"]) == (2.25, "float64")
    assert "/cam.name" not in by_name(update["message"])
    assert at - acknowledged <= 1.0, (
        f"the change reached the subscriber {at - acknowledged:.3f} s after the set"
    )


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_killed_node_is_unset_for_subscribers_and_left_out_of_get_all(
    fleet: Fleet, subprotocol: str
) -> None:
    subscriber = start_node("subscribe.js", fleet.url, subprotocol, "40", "/cam.speed", "/arm.speed")
    fleet.procs.append(subscriber)
    waits_for_event(subscriber, "subscribed")

    fleet.cam.kill()
    _, gone = waits_for_event(
        subscriber, "update", lambda e: "/cam.speed" in by_name(e["message"]), timeout=15
    )
    assert "value" not in by_name(gone["message"])["/cam.speed"], gone
    assert "/arm.speed" not in by_name(gone["message"])
    names = set(by_name(event(run_node("get.js", fleet.url, subprotocol), "reply")["message"]))
    assert names == {f"/{node}.{name}" for node in ("arm", "base") for name in EXPECTED}
    events = run_node("set.js", fleet.url, subprotocol, json.dumps([{"name": "/cam.name", "value": "x"}]))
    assert [as_pair(p) for p in event(events, "reply")["message"]["parameters"]] == [(None, None)]
    (status,) = [e["message"] for e in events if e["event"] == "status"]
    assert status["level"] == 2 and status["id"] == "set-1" and "cam" in status["message"], status

    fleet.restart_cam()
    _, back = waits_for_event(
        subscriber, "update", lambda e: "value" in by_name(e["message"]).get("/cam.speed", {}), timeout=15
    )
    assert as_pair(by_name(back["message"])["/cam.speed"]) == (1.5, "float64")
    names = set(by_name(event(run_node("get.js", fleet.url, subprotocol), "reply")["message"]))
    assert names == {f"/{node}.{name}" for node in NODES for name in EXPECTED}


def test_two_clients_at_once_each_get_their_answers_and_the_updates(fleet: Fleet) -> None:
    first, second = (
        start_node("subscribe.js", fleet.url, subprotocol, "20", "/base.name") for subprotocol in SUBPROTOCOLS
    )
    fleet.procs += [first, second]
    for subscriber in (first, second):
        waits_for_event(subscriber, "subscribed")
    getters = [start_node("get.js", fleet.url, subprotocol) for subprotocol in SUBPROTOCOLS]
    fleet.procs += getters
    for getter in getters:
        _, reply = waits_for_event(getter, "reply")
        assert len(reply["message"]["parameters"]) == len(NODES) * len(EXPECTED)

    request = [{"name": "/base.name", "value": "both"}]
    reply = event(run_node("set.js", fleet.url, SUBPROTOCOLS[0], json.dumps(request)), "reply")["message"]
    assert as_pair(by_name(reply)["/base.name"]) == ("both", None)
    for subscriber in (first, second):
        _, update = waits_for_event(subscriber, "update")
        assert as_pair(by_name(update["message"])["/base.name"]) == ("both", None)


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_client_dropping_mid_call_harms_nobody(fleet: Fleet, subprotocol: str) -> None:
    watcher = start_node("subscribe.js", fleet.url, subprotocol, "30", "/arm.count")
    fleet.procs.append(watcher)
    waits_for_event(watcher, "subscribed")

    request = [{"name": "/arm.count", "value": 11}, {"name": "/base.speed", "value": 0.5, "type": "float64"}]
    events = run_node("disconnect.js", fleet.url, subprotocol, "20", json.dumps(request))
    assert len([e for e in events if e["event"] == "dropped"]) == 20

    again = [{"name": "/arm.count", "value": 12}]
    reply = event(run_node("set.js", fleet.url, subprotocol, json.dumps(again)), "reply")["message"]
    assert as_pair(by_name(reply)["/arm.count"]) == (12, None)
    waits_for_event(watcher, "update", lambda e: by_name(e["message"])["/arm.count"].get("value") == 12)
    everything = event(run_node("get.js", fleet.url, subprotocol), "reply")["message"]
    assert len(everything["parameters"]) == len(NODES) * len(EXPECTED)
    assert_server_alive(fleet)


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_descriptors_and_blame_channel_carries_each_nodes_parameters(fleet: Fleet, subprotocol: str) -> None:
    watcher = start_node("channel.js", fleet.url, subprotocol, "/paramdds/parameters", "20")
    fleet.procs.append(watcher)
    _, advertised = waits_for_event(watcher, "advertised")
    assert advertised["channel"]["encoding"] == "json"
    assert json.loads(advertised["channel"]["schema"])["type"] == "object"
    first: dict[str, dict[str, Any]] = {}
    while len(first) < len(NODES):
        _, message = waits_for_event(watcher, "message")
        first.setdefault(message["data"]["node"], message["data"])
    assert set(first) == set(NODES)
    arm = {row["parameter"]: row for row in first["arm"]["parameters"]}
    assert set(arm) == set(EXPECTED)
    assert arm["speed"]["descriptor"]["floating_point_range"]["to_value"] == 5.0
    assert arm["fixed"]["descriptor"]["read_only"] is True

    request = [{"name": "/arm.speed", "value": 2.5, "type": "float64"}]
    events = run_node("set.js", fleet.url, subprotocol, json.dumps(request))
    assert as_pair(by_name(event(events, "reply")["message"])["/arm.speed"]) == (2.5, "float64"), events
    _, changed = waits_for_event(
        watcher,
        "message",
        lambda e: e["data"]["node"] == "arm" and e["data"]["revision"] > first["arm"]["revision"],
    )
    speed = {row["parameter"]: row for row in changed["data"]["parameters"]}["speed"]
    assert speed["value"] == 2.5
    last = speed["last_change"]
    assert last["via"] == "foxglove" and last["who"] and last["revision"] == changed["data"]["revision"], last
    assert isinstance(last["verified"], bool) and last["time"], last


def test_a_set_to_a_node_nobody_serves_is_an_error_status(fleet: Fleet) -> None:
    events = run_node("set.js", fleet.url, SUBPROTOCOLS[0], json.dumps([{"name": "/ghost.x", "value": 1}]))
    assert [as_pair(p) for p in event(events, "reply")["message"]["parameters"]] == [(None, None)]
    (status,) = [e["message"] for e in events if e["event"] == "status"]
    assert status["level"] == 2 and status["id"] == "set-1" and "ghost" in status["message"], status


def test_a_token_in_the_url_lets_a_browser_client_set_under_its_name(
    domain_id: int, tmp_path: Path, node_dir: Path
) -> None:
    token = "0123456789abcdef-carol"
    tokens = tmp_path / "tokens"
    tokens.write_text(f"carol {token}\n")
    fleet = Fleet(domain_id, tmp_path)
    try:
        fleet.start("--token-file", str(tokens))
        request = json.dumps([{"name": "/arm.count", "value": 5}])
        for url in (fleet.url, f"{fleet.url}/?token=not-the-token-at-all"):
            events = run_node("set.js", url, SUBPROTOCOLS[0], request)
            assert as_pair(by_name(event(events, "reply")["message"])["/arm.count"]) == (4, None)
            (status,) = [e["message"] for e in events if e["event"] == "status"]
            assert status["level"] == 2 and "token" in status["message"], status

        events = run_node("set.js", f"{fleet.url}/?token={token}", SUBPROTOCOLS[0], request)
        assert as_pair(by_name(event(events, "reply")["message"])["/arm.count"]) == (5, None)
        done = fleet.cli("describe", "arm", "count", "-o", "json")
        assert done.returncode == 0, done.stderr
        last = json.loads(done.stdout)["count"]["last_change"]
        assert (last["who"], last["via"]) == ("carol", "foxglove"), last
    finally:
        fleet.stop()
