"""Smoke test of ``paramdds bench web --quick``: it runs end to end and reports every figure.

No time is asserted below a number (a shared CI machine proves nothing); the
figures' targets are checked by a person reading the bench's table.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from .conftest import chromium_path

pytestmark = pytest.mark.slow


def test_bench_web_quick_reports_every_figure(domain: int) -> None:
    chromium_path()  # skips (or fails in CI) without a browser
    cmd = [sys.executable, "-m", "paramdds.cli", "bench", "web", "--quick", "--requests", "10"]
    cmd += ["--nodes", "20", "-o", "json", "--localhost", "-d", str(domain)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=150, env=dict(os.environ))
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["changes"] == 10 and data["nodes"] == 20 and data["params_per_node"] == 50
    for key in ("dom_p50_ms", "dom_p99_ms", "monitor_p50_ms", "monitor_p99_ms"):
        assert isinstance(data[key], (int, float)) and data[key] >= 0, (key, data[key])
    assert data["dom_p99_ms"] >= data["dom_p50_ms"]
    assert data["first_render_ms"] > 0 and data["api_nodes_ms"] > 0
