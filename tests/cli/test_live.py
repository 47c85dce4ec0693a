"""The verbs that stay up: watch, assign, server, client — their output and Ctrl-C (exit 130)."""

from __future__ import annotations

import json
import signal
import time

import pytest

from ._support import Proc, next_domain, run_cli, start_server


@pytest.mark.slow
def test_watch_json_then_ctrl_c(params_file: object) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "-p", str(params_file))
    watch = Proc(domain, ["watch", "-o", "json", "--prefix", "robot"])
    try:
        watch.wait_for('"synced"')
        first = [json.loads(line) for line in watch.lines]
        assert first[-1] == {"event": "synced"}
        added = first[:-1]
        assert {e["event"] for e in added} == {"added"} and len(added) == 5  # sensor.* filtered out
        velocity = next(e for e in added if e["name"] == "robot.max_velocity")
        assert set(velocity) == {"event", "node", "name", "type", "value", "revision", "stamp"}
        assert (velocity["node"], velocity["type"], velocity["value"]) == ("robot1", "double", 1.5)
        assert len({e["revision"] for e in added}) == 1

        assert (
            run_cli(
                domain,
                "set",
                "robot1",
                "--atomic",
                "robot.max_velocity=2",
                "robot.wheel_count=6",
                "sensor.rate_hz=10",
            ).returncode
            == 0
        )
        watch.wait_for("robot.wheel_count")
        changes = [json.loads(line) for line in watch.lines[len(first) :]]
        changes += [json.loads(line) for line in watch.drain(0.3)]
        assert {(e["event"], e["name"], e["value"]) for e in changes} == {
            ("modified", "robot.max_velocity", 2.0),
            ("modified", "robot.wheel_count", 6),
        }
        assert len({e["revision"] for e in changes}) == 1  # one atomic set, one revision

        assert server.stop() == 0
        offline = json.loads(watch.wait_for('"offline"'))
        assert (offline["node"], offline["event"]) == ("robot1", "offline")
    finally:
        server.stop()
        assert watch.stop(signal.SIGINT) == 130
    assert "Traceback" not in watch.stderr()


@pytest.mark.slow
def test_server_assign_and_client_end_with_130_on_ctrl_c(params_file: object) -> None:
    domain = next_domain()
    assign = Proc(domain, ["assign", "robot1", "robot.wheel_count=8"])
    assign.wait_for("[ASSIGN] holding 1 parameters for node robot1")
    server = start_server(domain, "-n", "robot1", "-p", str(params_file))
    client = Proc(domain, ["client", "-t", "robot1"])
    try:
        client.wait_for("=== SET PARAMETERS ===")
        assert wait_for_value(domain, "robot1", "robot.wheel_count", 8)  # the assignment arrived
    finally:
        codes = [p.stop(signal.SIGINT) for p in (client, server, assign)]
    assert codes == [130, 130, 130]
    for p in (client, server, assign):
        assert "Traceback" not in p.stderr()


def wait_for_value(domain: int, node: str, name: str, value: object, limit: float = 10.0) -> bool:
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        got = run_cli(domain, "get", node, name, "-o", "json")
        if got.returncode == 0 and json.loads(got.stdout) == {name: value}:
            return True
        time.sleep(0.2)
    return False


def test_nodes_on_an_empty_domain_is_empty() -> None:
    out = run_cli(next_domain(), "nodes", "-o", "json")
    assert (out.returncode, json.loads(out.stdout)) == (0, [])
