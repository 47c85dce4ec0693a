"""Standard Cyclone tooling sees our system: the ``cyclonedds`` CLI shipped with the wheel
reconstructs our types over XTypes, subscribes to ParameterEvents without any of our code,
and ``cyclonedds ps`` shows our process name, pid and host."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from paramdds.dds.participant import domain_config
from paramdds.dds.qos import QosProfiles

from .helpers import ServerProc, wait_until

pytestmark = pytest.mark.timeout(90)

CYCLONEDDS = shutil.which("cyclonedds", path=str(Path(sys.executable).parent)) or "cyclonedds"
APP = "paramdds-tooling-test"
WANTED_SAMPLES = [
    "ParameterEvent(",
    "node_id='tool_node'",
    "name='robot.name'",
    "string_value='rx-42'",
    "name='robot.speed'",
    "double_value=1.5",
]


def _start(domain_id: int, args: list[str], stdin: str = "") -> subprocess.Popen[str]:
    """The CLI with ``args``; ``stdin`` is its first input line (``--qos json`` reads the QoS there)."""
    env = dict(
        os.environ,
        CYCLONEDDS_URI=domain_config(localhost=True) or "",
        COLUMNS="250",
        NO_COLOR="1",
    )
    proc = subprocess.Popen(
        [CYCLONEDDS, *args, "-i", str(domain_id), "--suppress-progress-bar", "--color", "none"],
        stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    if proc.stdin is not None:
        proc.stdin.write(stdin + "\n")
        proc.stdin.close()
    return proc


def _finish(proc: subprocess.Popen[str], timeout: float = 45.0) -> str:
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, f"{proc.args} failed: {stderr}"
    return stdout


def _subscribe_until(proc: subprocess.Popen[str], wanted: list[str], timeout: float) -> str:
    """``cyclonedds subscribe`` runs until Ctrl-C: read until every wanted text was printed."""
    assert proc.stdout is not None
    seen: list[str] = []
    reader = threading.Thread(target=lambda: seen.extend(proc.stdout or ()), daemon=True)
    reader.start()
    try:
        wait_until(lambda: all(w in "".join(seen) for w in wanted), timeout, interval=0.05)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)
        reader.join(5)
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()
    return "".join(seen)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which(CYCLONEDDS) is None, reason="the cyclonedds CLI is not installed")
def test_cyclonedds_cli_sees_types_samples_and_process(domain_id: int) -> None:
    node = {"id": "tool_node", "params": {"robot.speed": 1.5, "robot.name": "rx-42"}}
    with ServerProc(domain_id, [node], app_name=APP) as server:
        typeof = _start(domain_id, ["typeof", "ParameterEvents", "-r", "2s"])
        ps = _start(domain_id, ["ps", "-r", "2s"])
        subscribe = _start(
            domain_id,
            ["subscribe", "ParameterEvents", "-r", "2s", "--qos", "json", "--type", "scan-random"],
            # the State profile: a scan would find the claim writers' partition too (wire.md)
            json.dumps(QosProfiles.load().reader("ParameterEvents").asdict()),
        )
        samples = _subscribe_until(subscribe, WANTED_SAMPLES, timeout=30.0)
        out = {"typeof": _finish(typeof), "ps": _finish(ps), "subscribe": samples}

    typeof = out["typeof"]
    assert "module paramdds" in typeof
    assert "struct ParameterEvent" in typeof
    assert "@key" in typeof and "node_id" in typeof and "parameter_count" in typeof

    samples = out["subscribe"]
    for text in WANTED_SAMPLES:
        assert text in samples, samples[-2000:]

    ps = out["ps"]
    rows = [line for line in ps.splitlines() if APP in line]
    assert rows, ps
    assert str(server.pid) in rows[0]
    assert socket.gethostname()[:10] in rows[0]
    assert "ParameterEvents" in ps and "SetParametersRequest" in ps
