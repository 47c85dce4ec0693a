"""``paramdds bench zenoh --quick``: runs end to end, and one site's uplink carries a change once.

No time is asserted (a shared machine proves nothing about speed); the bytes a site's
gateway sends up per change must not grow with the number of remote viewers, and those of
the same fleet as one stretched DDS domain do (measured as root, in a network namespace).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = [pytest.mark.slow, pytest.mark.timeout(150)]


def test_bench_zenoh_quick(domain_id: int) -> None:
    cmd = [sys.executable, "-m", "paramdds.cli", "bench", "zenoh", "--quick", "--sites", "1", "-o", "json"]
    cmd += ["--localhost", "-d", str(domain_id)]
    done = subprocess.run(
        cmd, capture_output=True, text=True, timeout=140, env=dict(os.environ, PARAMDDS_LOCALHOST="1")
    )
    assert done.returncode == 0, done.stderr
    (run,) = json.loads(done.stdout)["runs"]
    for key in (
        "remote_full_state_s",
        "dds_full_state_s",
        "uplink_bytes_per_change_1",
        "uplink_bytes_per_change_10",
    ):
        assert run[key] > 0, (key, run)
    for key in ("remote_get_ms", "dds_get_ms", "remote_set_ms", "dds_set_ms"):
        p50, p99 = run[key]
        assert 0 < p50 <= p99, (key, run)
    one, ten = run["uplink_bytes_per_change_1"], run["uplink_bytes_per_change_10"]
    assert 100 < one < 5000, run  # a delta of one parameter, not the node's whole state
    assert ten < 1.5 * one, f"the uplink carried more per change with 10 viewers: {one:.0f} -> {ten:.0f} B"
    # the stretched DDS domain's uplink (site 0 in a network namespace: root only): a copy per viewer
    why = run["dds_uplink_not_measured"]
    if why is None:
        one, ten = run["dds_uplink_bytes_per_change_1"], run["dds_uplink_bytes_per_change_10"]
        assert one > 100 and ten > 3 * one, f"one DDS domain: {one:.0f} B per change, then {ten:.0f} B"
    else:
        assert os.geteuid() != 0 or "ip" in why, why
        assert run["dds_uplink_bytes_per_change_1"] is None
