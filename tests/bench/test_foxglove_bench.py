"""``paramdds bench foxglove`` and ``bench record`` end to end at their smallest sizes.

Real processes (server workers, ``paramdds foxglove``, ``paramdds record``, rclpy hosts);
the JSON must carry every figure, and what was counted must add up. No time is compared
with a number: timings on a shared machine prove nothing.
"""

from __future__ import annotations

import pytest

from paramdds.ros2 import missing
from tests.bench.test_bench_smoke import bench


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_foxglove_get_all_and_change_latency_beside_the_bridge_way(domain_id: int) -> None:
    data = bench(
        "foxglove",
        domain_id,
        "--nodes",
        "6",
        "--ros-nodes",
        "3",
        "--params",
        "4",
        "--rounds",
        "2",
        "--requests",
        "5",
    )
    rows = {row["nodes"]: row for row in data["rows"]}
    fox = rows[6]["paramdds"]
    assert fox["params"] == 6 * 4  # a get-all held every parameter of every node
    assert fox["ready_nodes"] <= 6 and fox["servers"] == 1
    assert len(fox["fresh_ms"]) == len(fox["warm_ms"]) == 2 and min(fox["warm_ms"]) > 0
    assert fox["reply_bytes"] > 0
    assert 0 < fox["change_ms"]["p50"] <= fox["change_ms"]["p99"]
    assert fox["changes_lost"] == 0
    if missing():
        assert data["ros_skipped"] == missing() and 3 not in rows
        return
    ros = rows[3]["ros"]
    assert ros["answered"] == [3, 3] and ros["ignored"] == 0
    assert ros["params"] == [3 * (4 + 2)] * 2  # every rclpy node also declares two of its own
    assert 0 < ros["change_ms"]["p50"] <= ros["change_ms"]["p99"]


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_record_cpu_and_bytes_per_change(domain_id: int) -> None:
    data = bench("record", domain_id, "--rates", "20", "--seconds", "1", "--nodes", "2", "--params", "4")
    assert data["idle"]["rate"] == 0 and data["idle"]["recorded"] == 0
    (row,) = data["rows"]
    assert row["rate"] == 20 and row["changes"] == row["sent"] == 20
    assert row["recorded"] == row["changes"]  # the recording holds every change the server made
    assert row["file_bytes"] > data["idle"]["file_bytes"] and row["bytes_per_change"] > 0
    assert row["record_cpu_ms"] >= 0 and row["watch_cpu_ms"] >= 0
