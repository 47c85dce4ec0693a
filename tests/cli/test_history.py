"""``history``, ``diff`` and ``watch --since`` against a real server: who changed what, when, through what.

Changes are made by claimed identities through the command line (``--as``, and
``PARAMDDS_AS``), the Python API (``as_=``) and a file load, plus one refused write;
``history`` lists each in order, ``diff`` compares the node with its dump and with its
past, and ``watch --since`` misses nothing across its seam and across a stall.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path

import pytest

from ..dds.helpers import DdsSession
from ._support import PARAMDDS, Proc, cli_env, next_domain, run_cli, start_server

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]  # real CLI processes: ~15 s

NODE = "robot1"


def run_as(domain: int, who: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``paramdds ARGS`` with ``PARAMDDS_AS=who`` in its environment."""
    env = {**cli_env(domain), "PARAMDDS_AS": who}
    return subprocess.run([PARAMDDS, *args], env=env, capture_output=True, text=True, timeout=30)


@pytest.fixture
def node(params_file: Path) -> Iterator[tuple[int, Proc]]:
    domain = next_domain()
    server = start_server(domain, "-n", NODE, "-p", str(params_file))
    yield domain, server
    server.stop()


def history(domain: int, *args: str) -> list[dict[str, object]]:
    done = run_cli(domain, "history", NODE, *args, "-o", "json")
    assert done.returncode == 0, done.stderr
    records: list[dict[str, object]] = json.loads(done.stdout)
    return records


def test_history_lists_each_change_with_who_via_old_and_new(node: tuple[int, Proc], tmp_path: Path) -> None:
    domain, _ = node
    assert run_cli(domain, "set", NODE, "robot.max_velocity=2.5", "--as", "alice").returncode == 0
    assert run_as(domain, "bob", "set", NODE, "robot.name=bobs").returncode == 0
    with DdsSession(domain) as dds:
        reply = dds.client(as_="carol").set(NODE, {"robot.wheel_count": 6})
        assert reply.successful
    loaded = tmp_path / "load.yaml"
    loaded.write_text(f"{NODE}:\n  ros__parameters:\n    robot:\n      enabled: false\n")
    assert run_as(domain, "dave", "load", NODE, str(loaded)).returncode == 0
    refused = run_cli(domain, "set", NODE, "robot.wheel_count=many", "--as", "alice")
    assert refused.returncode == 1

    records = history(domain, "--since", "1")
    rows = [(r["name"], r["old"], r["new"], r["who"], r["via"], r["outcome"]) for r in records]
    assert rows == [
        ("robot.max_velocity", 1.5, 2.5, "alice", "cli", "applied"),
        ("robot.name", "my_robot", "bobs", "bob", "cli", "applied"),
        ("robot.wheel_count", 4, 6, "carol", "api", "applied"),
        ("robot.enabled", True, False, "dave", "load", "applied"),
        ("robot.wheel_count", 6, "many", "alice", "cli", "refused"),
    ]
    assert [r["revision"] for r in records] == [2, 3, 4, 5, 5]  # a refusal: the node's revision then
    assert all(r["verified"] is False for r in records)  # claims: plain mode verifies nobody
    assert "integer" in str(records[-1]["reason"])
    times = [str(r["time"]) for r in records]
    assert times == sorted(times) and all(t.endswith("Z") for t in times)

    start = history(domain)[:7]  # the values the node started with, from its file
    assert {r["via"] for r in start} == {"start"} and {r["old"] for r in start} == {None}

    table = run_cli(domain, "history", NODE, "robot.max_velocity", "--since", "1")
    assert table.returncode == 0
    assert table.stdout.count("\n") == 1
    assert "rev 2  robot.max_velocity: 1.5 → 2.5  by alice (claimed) via cli" in table.stdout

    assert [r["who"] for r in history(domain, "--who", "b*")] == ["bob"]
    assert [r["name"] for r in history(domain, "--refused")] == ["robot.wheel_count"]
    assert history(domain, "--since", "2099-01-01T00:00:00Z") == []
    assert len(history(domain, "--until", "2000-01-01")) == 0


def test_bad_input_is_one_line_and_its_exit_code(node: tuple[int, Proc]) -> None:
    domain, _ = node
    for args, code in (
        (["history", NODE, "--since", "yesterday"], 2),
        (["history", NODE, "--until", "soon"], 2),
        (["history", "ghost"], 3),
        (["diff", NODE, "robot1@tomorrow"], 2),
        (["diff", "ghost", NODE], 3),
        (["diff", "nope.yaml", NODE], 2),
        (["watch", NODE, "--since", "99"], 2),
        (["watch", "robot*", "--since", "1"], 2),
    ):
        done = run_cli(domain, *args)
        assert done.returncode == code, (args, done.stderr)
        assert done.stderr.count("\n") == 1 and done.stderr.startswith("paramdds: error: "), done.stderr
        assert "Traceback" not in done.stderr


def test_diff_against_the_dump_then_a_change_then_the_past(node: tuple[int, Proc], tmp_path: Path) -> None:
    domain, _ = node
    dump = tmp_path / "robot1.yaml"
    dumped = run_cli(domain, "dump", NODE)
    assert dumped.returncode == 0
    dump.write_text(dumped.stdout)
    same = run_cli(domain, "diff", NODE, str(dump))
    assert (same.returncode, same.stdout, same.stderr) == (0, "", "")

    before = datetime.now(timezone.utc).isoformat()
    time.sleep(0.05)
    assert run_cli(domain, "set", NODE, "robot.max_velocity=2.5", "--as", "alice").returncode == 0
    changed = run_cli(domain, "diff", NODE, str(dump))
    assert (changed.returncode, changed.stdout) == (1, "robot.max_velocity: 2.5 → 1.5\n")

    past = run_cli(domain, "diff", f"{NODE}@{before}", NODE)
    assert (past.returncode, past.stdout) == (1, "robot.max_velocity: 1.5 → 2.5\n")
    at_one = run_cli(domain, "diff", f"{NODE}@1", str(dump))
    assert (at_one.returncode, at_one.stdout) == (0, "")

    fleet = run_cli(domain, "diff", "robot*", str(dump), "-o", "json")
    assert fleet.returncode == 1
    (block,) = json.loads(fleet.stdout)
    assert block["node"] == NODE and block["equal"] is False
    assert block["differences"] == [{"name": "robot.max_velocity", "kind": "changed", "a": 2.5, "b": 1.5}]


def _changes(lines: list[str]) -> list[tuple[int, str, object]]:
    events = [json.loads(line) for line in lines]
    kinds = ("added", "modified", "deleted")
    return [(e["revision"], e["name"], e["value"]) for e in events if e["event"] in kinds]


@pytest.mark.slow
def test_watch_since_misses_nothing_across_the_seam_and_a_stall(node: tuple[int, Proc]) -> None:
    domain, _ = node
    for v in range(1, 4):
        assert run_cli(domain, "set", NODE, f"robot.wheel_count={v}").returncode == 0  # revisions 2-4
    with DdsSession(domain) as dds:
        client = dds.client(as_="writer")
        watch = Proc(domain, ["watch", NODE, "--since", "2", "-o", "json"])
        try:
            for v in range(10, 30):  # changes while the watch replays and goes live: the seam
                client.set(NODE, {"robot.wheel_count": v})
            watch.wait_for('"synced"')
            os.kill(watch.popen.pid, signal.SIGSTOP)  # a reader that falls behind
            for v in range(30, 60):
                client.set(NODE, {"robot.wheel_count": v, "robot.max_velocity": v / 100})
            os.kill(watch.popen.pid, signal.SIGCONT)
            watch.wait_for('"revision": 54', timeout=20)
            watch.drain(1.0)
        finally:
            watch.stop(signal.SIGINT)
    seen = _changes(watch.lines)
    expected = [(r["revision"], r["name"], r["new"]) for r in history(domain, "--since", "2")]
    assert seen == expected  # each change once, in revision order, with nothing missed
    assert [r for r, _, _ in seen] == [3, 4, *range(5, 25), *[r for r in range(25, 55) for _ in (0, 1)]]


def test_a_node_that_keeps_no_history_is_one_line_and_exit_1() -> None:
    from paramdds.core.table import ParameterTable

    domain = next_domain()
    with DdsSession(domain) as dds:
        table = ParameterTable("old_peer")
        table.declare("speed", 1.0)
        server = dds.server(table)
        server._histories.pop("old_peer")  # what a peer without history answers: history_kept FALSE
        for args in (
            ["history", "old_peer"],
            ["diff", "old_peer@1", "old_peer"],
            ["watch", "old_peer", "--since", "0"],
        ):
            done = run_cli(domain, *args)
            assert done.returncode == 1, (args, done.stderr)
            assert done.stderr.count("\n") == 1 and "history" in done.stderr, done.stderr
