"""Smoke test of ``paramdds bench schema --quick``: it runs end to end and reports every figure
(never a time threshold: timings on a shared machine prove nothing)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import pytest

from tests.support.realworld import find_realworld

pytestmark = pytest.mark.slow


def bench(scenario: str, domain_id: int) -> dict[str, Any]:
    cmd = [sys.executable, "-m", "paramdds.cli", "bench", scenario, "--quick", "-o", "json", "--localhost"]
    env = dict(os.environ, PARAMDDS_LOCALHOST="1")
    done = subprocess.run([*cmd, "-d", str(domain_id)], capture_output=True, text=True, timeout=150, env=env)
    assert done.returncode == 0, done.stderr
    data: dict[str, Any] = json.loads(done.stdout)
    return data


def positive(data: dict[str, Any], *keys: str) -> None:
    for key in keys:
        assert isinstance(data.get(key), (int, float)) and data[key] > 0, f"{key} = {data.get(key)!r}"


@pytest.mark.skipif(find_realworld() is None, reason="shared/realworld is absent (CI has it)")
def test_schema(domain_id: int) -> None:
    data = bench("schema", domain_id)
    for system in ("schema_set1", "spec_set1", "schema_set10", "spec_set10"):
        positive(data, f"{system}_p50_us", f"{system}_p99_us")
    positive(data, "ratio_set1_p50", "ratio_set1_p99", "check_autoware_ms", "python_import_ms")
    assert data["schema_file"] == "autoware_multi_object_tracker/schema/input_channels.schema.json"
    assert (data["parameters"], data["schemas"], data["pairs"]) == (48, 16, 18)
