"""``assign`` reports each node's answer as it happens: every refusal with the node's reason,
on stdout and with ``-o json``, when the node starts and when it is already up. Real servers."""

from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest

from ._support import Proc, next_domain, start_server

ROOT = Path(__file__).resolve().parents[2]
SPEC = str(ROOT / "examples" / "robot_spec.yaml")
PARAMS = str(ROOT / "examples" / "params.yaml")


@pytest.mark.slow
def test_assign_prints_refusals_with_the_reason() -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "--spec", SPEC, "-p", PARAMS)
    assign = Proc(domain, ["assign", "robot1", "robot.wheel_count=6", "robot.max_velocity=2.0"])
    try:
        assign.wait_for("[ASSIGN] holding 2 parameters for node robot1")
        line = assign.wait_for("[ASSIGN] node robot1 applied 1 of 2 parameters", timeout=15)
        assert "(revision 2)" in line
        refused = assign.wait_for("robot.wheel_count")
        assert refused == "[ASSIGN]   robot.wheel_count: FAILED: parameter 'robot.wheel_count' is read-only"
    finally:
        server.stop()
        assign.stop(signal.SIGINT)


@pytest.mark.slow
def test_assign_json_reports_each_start_of_the_node() -> None:
    domain = next_domain()
    assign = Proc(domain, ["assign", "robot1", "robot.max_velocity=9.0", "-o", "json"])
    try:
        assign.wait_for("[ASSIGN] holding 1 parameters")
        for _ in range(2):  # the node starts twice: two answers
            server = start_server(domain, "-n", "robot1", "--spec", SPEC, "-p", PARAMS)
            answer = json.loads(assign.wait_for('"assigned"', timeout=15))
            server.stop()
            assert answer["node"] == "robot1"
            result = answer["results"]["robot.max_velocity"]
            assert result["successful"] is False and "must be within [0.0, 5.0]" in result["reason"]
    finally:
        assign.stop(signal.SIGINT)
