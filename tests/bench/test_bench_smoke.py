"""Smoke tests of ``paramdds bench``: every scenario runs ``--quick -o json`` end to end.

They check that the JSON carries every key with a sane value and that the topic
counts are what the layouts imply. They never assert that a time is below a
number: timings on a shared CI machine prove nothing.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

TIMEOUT = 150


def bench(scenario: str, domain_id: int, *extra: str) -> dict[str, Any]:
    cmd = [
        sys.executable,
        "-m",
        "paramdds.cli",
        "bench",
        scenario,
        "--quick",
        "-o",
        "json",
        "--localhost",
        "-d",
        str(domain_id),
        *extra,
    ]
    env = dict(os.environ, PARAMDDS_LOCALHOST="1")
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT, env=env)
    assert done.returncode == 0, done.stderr
    data: dict[str, Any] = json.loads(done.stdout)
    positive(data["python_loop_ms"], "before", "after")  # the machine-speed reference of every run
    return data


def positive(data: dict[str, Any], *keys: str) -> None:
    for key in keys:
        assert key in data, f"missing {key!r} in {data}"
        assert isinstance(data[key], (int, float)) and data[key] > 0, f"{key} = {data[key]!r}"


@pytest.mark.slow
def test_latency(domain_id: int) -> None:
    data = bench("latency", domain_id, "--viewers", "2")
    assert data["viewers"] == 2
    positive(
        data,
        "get_p50_us",
        "get_p99_us",
        "set_p50_us",
        "set_p99_us",
        "raw_p50_us",
        "raw_p99_us",
        "polling_p50_us",
        "ratio_get_raw",
    )
    assert data["get_p99_us"] >= data["get_p50_us"]
    assert data["raw_p99_us"] >= data["raw_p50_us"]


@pytest.mark.slow
def test_scaling(domain_id: int) -> None:
    data = bench("scaling", domain_id, "--nodes", "3,6")
    rows = data["rows"]
    assert [r["nodes"] for r in rows] == [3, 6]
    for r in rows:
        positive(
            r,
            "paramdds_full_state_ms",
            "baseline_full_state_ms",
            "paramdds_process_ms",
            "baseline_process_ms",
            "paramdds_topics",
            "baseline_topics",
            "paramdds_monitor_endpoints",
            "baseline_monitor_endpoints",
        )
        assert r["paramdds_topics"] == 7
        # six services x (request + reply) per node, plus the shared events topic
        assert r["baseline_topics"] == 12 * r["nodes"] + 1
        assert r["paramdds_monitor_endpoints"] == 1
        assert r["baseline_monitor_endpoints"] == 6 * r["nodes"]
    assert rows[1]["baseline_topics"] > rows[0]["baseline_topics"]


@pytest.mark.slow
def test_throughput(domain_id: int) -> None:
    data = bench("throughput", domain_id, "--seconds", "0.5")
    positive(data, "gets_per_s", "raw_per_s")


@pytest.mark.slow
def test_hosting(domain_id: int) -> None:
    data = bench("hosting", domain_id, "--nodes", "50")
    positive(data, "nodes", "rss_mb", "start_ms", "full_state_ms")
    assert data["nodes"] == 50


@pytest.mark.slow
def test_startup(domain_id: int) -> None:
    data = bench("startup", domain_id, "--rounds", "2")
    positive(data, "cli_get_ms", "import_floor_ms", "participant_floor_ms")


def test_codec(domain_id: int) -> None:
    data = bench("codec", domain_id)
    assert len(data["cases"]) == 14
    assert "decode state, bench node's 20 params, monitor" in {case["case"] for case in data["cases"]}
    for case in data["cases"]:
        positive(case, "paramdds_us", "binding_us", "speedup")


@pytest.mark.parametrize("argv", [["bench", "nosuch"], ["bench", "scaling", "--nodes", "0"]])
def test_bad_arguments_are_usage_errors(argv: list[str]) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "paramdds.cli", *argv], capture_output=True, text=True, timeout=30
    )
    assert done.returncode == 2, done.stderr


@pytest.mark.slow
def test_fleet(domain_id: int) -> None:
    data = bench("fleet", domain_id, "--servers", "2", "--nodes", "20", "--params", "4", "--rounds", "1")
    positive(data, "synced_ms", "get_fleet_ms", "get_empty_ms", "get_ratio", "foreign_rate")
    assert data["lo_bytes_per_request"] >= 0  # 0 where other traffic on lo swamps ours (shared host)
    assert data["get_server_cpu_ms"] >= 0 and data["get_lo_bytes_fleet"] > 0
    assert (data["servers"], data["nodes"], data["params_per_node"]) == (2, 40, 4)
    assert data["synced_params"] == 40 * 4  # the monitor held every parameter of every node
    assert data["request_readers"] == 4  # the fleet's two servers and the two measured ones
    assert data["cpu_native_ms_per_s"] >= 0 and data["cpu_handler_ms_per_s"] >= 0
    assert data["partition_client"]["1"]["writers"] == 1  # 100 and 1,000 need a fleet that large
    assert data["partition_client"]["1"]["matched_ms"] is not None
    assert set(data["lo_bytes_per_request_by_servers"]) == {"1", "2"}  # measured with 1, then 2 readers


@pytest.mark.slow
def test_persist(domain_id: int) -> None:
    data = bench("persist", domain_id, "--seconds", "0.3", "--params", "10", "--requests", "2000")
    positive(data, "sets_per_s_10", "sets_per_s_10_no_persist", "restart_ms", "restart_empty_journal_ms")
    assert data["journal_changes"] == 2000


ODD_NAMES = """\
/odd:
  ros__parameters:
    a: 1
    $(var p)joint:
      goal: 0.1
    c:
      ok: 2
      b$d: 3
    e:
      $x: 1
"""


@pytest.mark.slow
@pytest.mark.timeout(400)
def test_ros2_drops_names_paramdds_refuses_from_both_systems(domain_id: int, tmp_path: Path) -> None:
    """A real file may hold a name paramdds refuses (``$(var tf_prefix)…``, a launch
    substitution left in it): both systems get the set without it, and paramdds serves it."""
    from tests.ros2.conftest import require_ros2

    require_ros2()
    (tmp_path / "odd.yaml").write_text(ODD_NAMES)
    cmd = [sys.executable, "-m", "paramdds.cli", "bench", "ros2", "--quick", "--nodes", "2", "--servers", "1"]
    cmd += ["--requests", "10", "-o", "json", "--localhost", "-d", str(domain_id)]
    env = dict(os.environ, PARAMDDS_LOCALHOST="1", PARAMDDS_REALWORLD=str(tmp_path))
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=360, env=env)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["parameter_sets"] == 1
    (row,) = data["rows"]
    assert row["ros_complete"] == row["dds_complete"] == 2  # a refused name would stop the server


@pytest.mark.slow
def test_history_store(domain_id: int) -> None:
    data = bench("history-store", domain_id, "--requests", "100", "--records", "2000", "--rounds", "1")
    for size in (1, 8):
        for system in ("state", "journal", "sqlite"):
            assert all(v > 0 for v in data[f"us_per_change_g{size}_{system}"])
    assert data["kill9_journal_intact"] and data["kill9_sqlite_intact"]
    assert all(r["acknowledged"] > 0 for r in data["kill9_journal"] + data["kill9_sqlite"])
    (run,) = data["queries_1x2000"]
    assert run["q_name_rows"] > 0 and run["q_who_rows"] > 0
