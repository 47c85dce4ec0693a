"""The demo as a user runs it: ``run.sh --demo``, ``paramdds demo --once`` and its alias ``client``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ._support import ROOT, cli_env, next_domain, run_cli, start_server

EXAMPLE = ROOT / "examples" / "params.yaml"
NAMES = [
    "robot.enabled",
    "robot.max_acceleration",
    "robot.max_velocity",
    "robot.name",
    "robot.wheel_count",
    "sensor.frequencies",
    "sensor.topics",
]


def check_demo_output(out: str, node: str) -> None:
    lines = out.splitlines()
    assert lines[lines.index(f"[PARAM_EVENT] From node: {node}") + 1].startswith("  NEW: ")
    assert sorted(line[len("  NEW: ") :] for line in lines if line.startswith("  NEW: ")) == NAMES
    i = lines.index("=== LIST PARAMETERS ===")
    assert lines[i + 1] == f"[LIST] Found 7 parameters on {node}:"
    assert lines[i + 2 : i + 9] == [f"  - {n}" for n in NAMES]
    g = lines.index("=== GET PARAMETERS ===")
    assert lines[g + 1] == "[GET] Retrieved 7 parameters:"
    assert "  robot.max_velocity = double 1.5" in lines[g + 2 : g + 9]
    assert "  sensor.topics = string_array ['/scan', '/imu', '/odom']" in lines[g + 2 : g + 9]
    s = lines.index("=== SET PARAMETERS ===")
    assert lines[s + 1] == f"[SET] Response from: {node}"
    # the file's values are the node's: each shown with its value, unchanged, nothing sent
    results = lines[s + 2 : s + 9]
    assert all(r.startswith(f"  Result[{i}]: ") and r.endswith(": UNCHANGED") for i, r in enumerate(results))
    assert any(r.endswith(": robot.max_velocity = double 1.5: UNCHANGED") for r in results)
    assert "CHANGED: " not in out
    r = lines.index("=== A REFUSED SET ===")
    assert lines[r + 1] == "[SET] robot.enabled = string 'fast'"
    reason = "Parameter 'robot.enabled' expects a bool but got string 'fast'"
    assert lines[r + 2] == f"  Result[0]: FAILED: {reason}"


@pytest.mark.slow
def test_demo_once_prints_the_demo_and_client_is_its_alias(tmp_path: Path) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "-p", str(EXAMPLE))
    try:
        assert server.lines[0] == f"[SERVER] Loaded 7 parameters from {EXAMPLE}"
        out = run_cli(domain, "demo", "--target", "robot1", "--params-file", str(EXAMPLE), "--once")
        assert out.returncode == 0, out.stderr
        check_demo_output(out.stdout, "robot1")
        failing = tmp_path / "bad.yaml"
        failing.write_text("parameters:\n  - name: robot.name\n    type: integer\n    value: 3\n")
        out = run_cli(domain, "client", "--target", "robot1", "--params-file", str(failing), "--once")
        assert out.returncode == 1
        assert "  Result[0]: robot.name = integer 3: FAILED: " in out.stdout
        changed = tmp_path / "changed.yaml"
        changed.write_text("parameters:\n  - name: robot.max_velocity\n    type: double\n    value: 2.5\n")
        out = run_cli(domain, "client", "--target", "robot1", "--params-file", str(changed), "--once")
        assert out.returncode == 0, out.stderr
        assert "  Result[0]: robot.max_velocity = double 2.5: SUCCESS" in out.stdout.splitlines()
        assert "  CHANGED: robot.max_velocity" in out.stdout.splitlines()
    finally:
        assert server.stop() == 0  # SIGTERM is a graceful stop


def test_demo_exits_3_when_the_target_never_appears() -> None:
    out = run_cli(next_domain(), "demo", "--target", "nobody", "--wait", "1", "--once")
    assert out.returncode == 3
    assert "nobody" in out.stderr and out.stderr.count("\n") == 1


@pytest.mark.slow
def test_run_sh_demo() -> None:
    env = cli_env(next_domain())
    env["PARAMDDS_VENV"] = str(Path(sys.executable).parent.parent)
    out = subprocess.run(
        [str(ROOT / "run.sh"), "--demo", "-n", "robot1", "-d", env["PARAMDDS_DOMAIN"]],
        env=env,
        capture_output=True,
        text=True,
        timeout=180,
        cwd=os.fspath(ROOT),
    )
    assert out.returncode == 0, out.stderr
    assert f"[SERVER] Loaded 7 parameters from {EXAMPLE}" in out.stdout
    check_run_sh_demo_output(out.stdout, "robot1")


def check_run_sh_demo_output(out: str, node: str) -> None:
    """run.sh's client sets examples/demo_set.yaml: writes that succeed, the events they cause."""
    lines = out.splitlines()
    assert sorted(line[len("  NEW: ") :] for line in lines if line.startswith("  NEW: ")) == NAMES
    g = lines.index("=== GET PARAMETERS ===")
    assert "  robot.max_velocity = double 1.5" in lines[g + 2 : g + 9]
    s = lines.index("=== SET PARAMETERS ===")
    assert lines[s + 1 : s + 11] == [
        f"[SET] Response from: {node}",
        "  Result[0]: robot.max_velocity = double 2.5: SUCCESS",
        "  Result[1]: robot.max_acceleration = double 0.8: UNCHANGED",
        "  Result[2]: robot.name = string 'demo_robot': SUCCESS",
        "  Result[3]: robot.enabled = bool true: UNCHANGED",
        "  Result[4]: sensor.frequencies = double_array [10.0, 20.0, 100.0]: SUCCESS",
        f"[PARAM_EVENT] From node: {node}",
        "  CHANGED: robot.max_velocity",
        "  CHANGED: robot.name",
        "  CHANGED: sensor.frequencies",
    ]
    r = lines.index("=== A REFUSED SET ===")
    assert r == s + 12 and lines[r - 1] == ""
    assert lines[r + 1 :] == [
        "[SET] robot.enabled = string 'fast'",
        "  Result[0]: FAILED: Parameter 'robot.enabled' expects a bool but got string 'fast'",
    ]


def test_run_sh_rejects_bad_flags() -> None:
    out = subprocess.run([str(ROOT / "run.sh"), "-v", "9"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 2 and "verbosity" in out.stderr
    help_text = subprocess.run([str(ROOT / "run.sh"), "-h"], capture_output=True, text=True, timeout=30)
    assert help_text.returncode == 0
    for flag in (
        "--domain",
        "--verbosity",
        "--qos-file",
        "--params-file",
        "--node-name",
        "--target",
        "--server",
    ):
        assert flag in help_text.stdout
