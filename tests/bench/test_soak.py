"""``paramdds bench soak``: its verdicts (pure, fast) and a real one-minute run (slow).

The one-minute run starts every component this machine has the extras for, restarts servers
(cleanly and with SIGKILL) and the ROS 2 host, and must pass its own correctness checks: no
acknowledged write lost, no write reported failed that landed, no viewer wrong about presence
after the settle time, no viewer's value unlike the node's. Growth is reported, not judged.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.bench._soak_checks import growth, stale_values, traced, verify_writes, wrong_presence
from paramdds.bench.soak import _skipped


def test_a_correct_node_passes_and_each_kind_of_wrong_is_named() -> None:
    ledger = {"n1": {"p": {"applied": [1, 3], "failed": [2], "unknown": [4]}}}
    ok = verify_writes([ledger], {"n1": {"p": 3.0}}, {"n1": {"p": {1, 3}}})
    assert ok.ok and ok.acknowledged == 2 and ok.failed == 1 and ok.unknown == 1 and ok.unknown_landed == 0
    landed_unknown = verify_writes([ledger], {"n1": {"p": 4.0}}, {"n1": {"p": {1, 3, 4}}})
    assert landed_unknown.ok and landed_unknown.unknown_landed == 1
    lost = verify_writes([ledger], {"n1": {"p": 3.0}}, {"n1": {"p": {3}}})
    assert lost.lost == ["n1 p 1"] and not lost.ok
    landed = verify_writes([ledger], {"n1": {"p": 3.0}}, {"n1": {"p": {1, 2, 3}}})
    assert landed.landed_failed == ["n1 p 2"] and not landed.ok
    stale = verify_writes([ledger], {"n1": {"p": 1.0}}, {"n1": {"p": {1, 3}}})
    assert stale.wrong_final and not stale.ok
    missing = verify_writes([ledger], {}, {"n1": {"p": {1, 3}}})
    assert missing.wrong_final and not missing.ok


def test_a_lost_write_is_traced_to_the_server_life_that_acknowledged_it(tmp_path: Path) -> None:
    acks = tmp_path / "client0.acks"  # as a soak client writes it down
    acks.write_text("n1 1 7 00000000000000ab 1796052349.700\nn1 2 8 00000000000000ab 1796052349.950\n")
    assert traced([], [tmp_path / "absent"]) == []
    assert traced(["n1 p 1", "n1 q 3", "n2 p 1"], [acks, tmp_path / "absent"]) == [
        "n1 p 1: r7 incarnation 00000000000000ab at 1796052349.700",
        "n1 q 3: no acknowledgement written down",
        "n2 p 1: no acknowledgement written down",
    ]


def test_history_dropped_by_retention_is_judged_by_the_final_value() -> None:
    ledger = {"n1": {"p": {"applied": [1, 2, 3]}}}
    kept = verify_writes([ledger], {"n1": {"p": 3.0}}, {"n1": {"p": {2, 3}}}, compacted=["n1"])
    assert kept.ok and kept.compacted == ["n1"]
    assert not verify_writes([ledger], {"n1": {"p": 2.0}}, {"n1": {"p": {2}}}, compacted=["n1"]).ok


@given(st.lists(st.sampled_from(["applied", "failed", "unknown", "unknown-landed"]), min_size=1, max_size=40))
def test_what_a_true_node_holds_always_passes_and_any_lie_fails(outcomes: list[str]) -> None:
    ledger: dict[str, list[int]] = {}
    applied: set[int] = set()
    for seq, said in enumerate(outcomes, start=1):
        ledger.setdefault(said.split("-")[0], []).append(seq)
        if said in ("applied", "unknown-landed"):
            applied.add(seq)
    final = float(max(applied, default=0))
    assert verify_writes([{"n": {"p": ledger}}], {"n": {"p": final}}, {"n": {"p": applied}}).ok
    if ledger.get("applied"):  # an acknowledged write the node lost
        lie = applied - {ledger["applied"][0]}
        assert not verify_writes([{"n": {"p": ledger}}], {"n": {"p": final}}, {"n": {"p": lie}}).ok
    if ledger.get("failed"):  # a write reported failed that the node applied
        lie = applied | {ledger["failed"][0]}
        held = float(max(lie))
        assert not verify_writes([{"n": {"p": ledger}}], {"n": {"p": held}}, {"n": {"p": lie}}).ok


def test_presence_values_and_growth() -> None:
    expected = {"a": True, "b": False, "c": True}
    assert wrong_presence({"a": True, "b": True}, expected) == {
        "online_but_gone": ["b"],
        "offline_but_there": ["c"],
    }
    assert wrong_presence({"a": True, "c": True, "x": True}, expected) == {
        "online_but_gone": [],
        "offline_but_there": [],
    }
    assert stale_values({"a": {"p": 1.0}}, {"a": {"p": 1.0}}) == []
    assert stale_values({"a": {"p": 1.0}}, {"a": {"p": 2.0}, "b": {"p": 0.0}}) == [
        "a p: shows 1.0, holds 2.0",
        "b p: shows None, holds 0.0",
    ]
    assert growth(100.0, 104.0) == 4.0 and growth(0.0, 5.0) == 0.0 and growth(50.0, 40.0) == -20.0


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_one_minute_soak_passes_its_checks(domain_id: int) -> None:
    cmd = [sys.executable, "-m", "paramdds.cli", "bench", "soak", "--minutes", "1", "-o", "json"]
    cmd += ["--localhost", "-d", str(domain_id)]
    env = dict(os.environ, PARAMDDS_LOCALHOST="1")
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=540, env=env)
    assert done.stdout, done.stderr
    data = json.loads(done.stdout)
    shown = {k: data[k] for k in ("writes", "presence", "stale_values", "died", "streams", "churn")}
    assert done.returncode == 0 and data["passed"], json.dumps(shown) + done.stderr[-3000:]
    assert data["skipped"] == _skipped()  # a component left out is said, never silently
    if os.environ.get("CI", "").strip().lower() in {"1", "true", "yes"}:
        assert data["skipped"] == {}  # CI installs every extra: the whole site runs there
    churn = data["churn"]
    assert churn["turns"] >= 5 and churn["server_kills"] >= 1 and churn["server_stops"] >= 1
    assert churn["server_unclean_stops"] == 0, churn  # every server SIGTERM asked to stop did
    if "ros2" not in data["skipped"]:
        assert churn["ros_host_restarts"] >= 1 and data["ros_nodes"] == 20
    writes = data["writes"]
    assert writes["acknowledged"] > 100 and writes["lost"] == writes["failed_but_landed"] == []
    assert data["presence"]["checks"] >= 2 * churn["turns"] and data["presence"]["wrong"] == []
    assert data["get"]["gets"] > 100 and 0 < data["get"]["ms"]["p50"] <= data["get"]["ms"]["p99"]
    expected = {"bench (this process)", "monitor1", "monitor2", "prober"}
    expected |= {f"client{k}" for k in range(4)}
    expected |= set() if "web" in data["skipped"] else {"web console"}
    expected |= set() if "zenoh" in data["skipped"] else {"zenoh gateway", "remote monitor"}
    expected |= set() if "ros2" in data["skipped"] else {"ros2 bridge"}
    assert set(data["processes"]) == expected
    for name, p in data["processes"].items():
        for sample in (p["warm"], p["end"]):
            assert sample["rss_mb"] > 0 and sample["threads"] >= 1 and sample["fds"] >= 3, name
            # every process wrote its C heap down (glibc): in use, MiBs with a participant
            assert sample["c_used_mb"] > 1.0 and sample["c_free_mb"] >= 0.0, name
    assert data["warm_at_s"] >= 20 and data["end_at_s"] >= 55
    if "web" not in data["skipped"]:
        assert [s["reconnects"] for s in data["streams"]] == [0, 0]
        assert all(s["events"].get("nodes", 0) > 0 for s in data["streams"])


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_soak_stopped_by_sigterm_leaves_no_temporary_directory(domain_id: int, tmp_path: Path) -> None:
    cmd = [sys.executable, "-m", "paramdds.cli", "bench", "soak", "--minutes", "1", "-o", "json"]
    cmd += ["--localhost", "-d", str(domain_id)]
    env = dict(os.environ, PARAMDDS_LOCALHOST="1", TMPDIR=str(tmp_path))
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 30
    while not list(tmp_path.glob("paramdds-soak-*")) and time.monotonic() < deadline:
        time.sleep(0.05)  # until it has made its directory
    assert list(tmp_path.glob("paramdds-soak-*")), "the soak made no directory in 30 s"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=90)
    assert proc.returncode == 0, err[-2000:]  # a graceful stop
    assert list(tmp_path.glob("paramdds-soak-*")) == []


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_memory_churn_counts_lives_and_its_decoder_keeps_one_entry_a_server_life(domain_id: int) -> None:
    """``python -m paramdds.bench._soak_memory``, 20 s: servers restarted, watchers looked at,
    and a monitor's decoder holding an entry per server life and per author, not per node."""
    cmd = [sys.executable, "-m", "paramdds.bench._soak_memory", "-d", str(domain_id), "--localhost"]
    cmd += ["--minutes", "0.33", "--servers", "1", "--nodes", "4", "--watch", "monitor,traced,bare"]
    cmd += ["-o", "json"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0 and done.stdout, done.stderr[-3000:]
    data = json.loads(done.stdout)
    timeline = [(look["at_s"], look["lives"]) for look in data["series"]]
    assert data["unclean_stops"] == 0, done.stderr[-3000:]  # a server SIGTERM did not end stalled the churn
    looks = (data["warm_at_s"], data["end_at_s"], timeline)
    assert data["lives"] >= 4 and data["lives_after_warm_up"] >= 2, looks
    assert set(data["watchers"]) == {"monitor", "traced", "bare"}
    assert data["watchers"]["traced"]["heap_mib_per_100_lives"] is not None and data["heap_grown_kib"]
    heap = data["watchers"]["bare"]["c_heap_mb"][1]  # glibc's count: a participant's C heap is MiBs
    assert heap["used"] > 1.0 and heap["free"] >= 0.0
    caches = data["watchers"]["monitor"]["caches"][1]
    assert caches["heads"] <= data["lives"] and caches["blames"] <= 4  # 2 authors and the servers' own
