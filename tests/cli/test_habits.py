"""What an operator types out of habit works: ``ros2 param``'s ``set NODE NAME VALUE`` and
``NAME:=VALUE``, ``--version``, ``python -m paramdds``, ``web --port``, and a bad parameter
name is a local usage error (exit 2) like a bad node name. Real servers on loopback."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from ._support import Proc, cli_env, next_domain, run_cli, start_server


@pytest.mark.slow
def test_set_takes_ros2_param_forms(params_file: Path) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "-p", str(params_file))
    try:
        one = run_cli(domain, "set", "/robot1", "robot.max_velocity", "2.0", "-o", "json")
        assert one.returncode == 0, one.stderr
        assert json.loads(one.stdout)["robot.max_velocity"]["successful"] is True
        walrus = run_cli(domain, "set", "robot1", "robot.max_velocity:=3.0", "robot.wheel_count:=6")
        assert walrus.returncode == 0, walrus.stderr
        got = run_cli(domain, "get", "robot1", "robot.max_velocity", "robot.wheel_count", "-o", "json")
        assert json.loads(got.stdout) == {"robot.max_velocity": 3.0, "robot.wheel_count": 6}
        # NAME=VALUE pairs stay as they were; two of them are never taken for NAME VALUE
        pairs = run_cli(domain, "set", "robot1", "robot.max_velocity=1.0", "robot.wheel_count=4")
        assert pairs.returncode == 0, pairs.stderr
    finally:
        server.stop()


@pytest.mark.slow
def test_a_bad_parameter_name_is_a_usage_error_without_a_node() -> None:
    domain = next_domain()  # no server: the name is refused before anything is sent
    for verb in ("get", "describe", "delete"):
        out = run_cli(domain, verb, "robot1", "bad name!")
        assert out.returncode == 2, (verb, out.stderr)
        assert "invalid parameter name 'bad name!'" in out.stderr


def test_version_and_python_m() -> None:
    out = run_cli(next_domain(), "--version")
    assert out.returncode == 0 and out.stdout.startswith("paramdds "), out
    module = subprocess.run(
        [sys.executable, "-m", "paramdds", "--version"], capture_output=True, text=True, env=cli_env(0)
    )
    assert (module.returncode, module.stdout) == (0, out.stdout)


def test_web_port() -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    web = Proc(next_domain(), ["web", "--port", str(port)])
    try:
        assert f"http://127.0.0.1:{port}/" in web.wait_for("[WEB] Console on", timeout=30)
    finally:
        web.stop()
