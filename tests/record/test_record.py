"""``paramdds record`` against real servers: the snapshot, every change with its author, SIGTERM and kill -9.

A recorder runs as a process on the test's own domain while ``paramdds set`` changes the
nodes; the file is read back with the ``mcap`` package: the snapshot equals the nodes'
state, every change is there in order with who made it, SIGTERM finishes the file
(summary and footer), and a ``kill -9`` leaves a file readable up to its tear that holds
every change made more than 2 s before the kill.
"""

from __future__ import annotations

import json
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from ..reliability.conftest import Proc, start_server
from ._support import NAMES, PARAMS, cli, messages, set_as, start_recorder, stream_messages

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]  # real servers and a recorder: ~10 s each


SERVERS: dict[int, dict[str, Proc]] = {}  # a test's servers by domain, to stop one of them


@pytest.fixture
def nodes(domain_id: int, tmp_path: Path) -> Iterator[int]:
    params = tmp_path / "params.yaml"
    params.write_text(PARAMS)
    servers = {name: start_server(domain_id, "-n", name, "-p", str(params)) for name in ("robot1", "robot2")}
    SERVERS[domain_id] = servers
    yield domain_id
    for s in servers.values():
        s.stop()
    del SERVERS[domain_id]


def _state(domain: int, node: str) -> dict[str, object]:
    done = cli(domain, "get", node, *NAMES, "-o", "json")
    assert done.returncode == 0, done.stderr
    return dict(json.loads(done.stdout))


def test_snapshot_then_every_change_in_order_with_its_author_and_sigterm_finishes(
    nodes: int, tmp_path: Path
) -> None:
    domain = nodes
    path = tmp_path / "rec.mcap"
    rec = start_recorder(domain, path)
    try:
        assert "Recording 2 nodes to" in rec.lines[-1][1]
        set_as(domain, "alice", "robot1", "robot.max_velocity=2.5")
        set_as(domain, "bob", "robot2", "robot.name=bobs", "robot.wheel_count=6")
        set_as(domain, "carol", "robot1", "robot.enabled=false")
        set_as(domain, "alice", "robot1", "robot.max_velocity=3.0")
        time.sleep(1.0)
        now = {n: _state(domain, n) for n in ("robot1", "robot2")}
        SERVERS[domain]["robot2"].stop()  # a graceful stop: offline at once
        time.sleep(1.5)
    finally:
        assert rec.stop() == 0, rec.stderr_text()

    msgs = messages(path)  # make_reader needs the summary and footer: SIGTERM wrote them
    snaps = {b["node"]: b for t, _, b in msgs if t == "/paramdds/snapshot"}
    assert set(snaps) == {"robot1", "robot2"}
    for snap in snaps.values():
        values = {p["name"]: p["value"]["value"] for p in snap["parameters"]}
        assert values == {
            "robot.max_velocity": 1.5, "robot.name": "my_robot", "robot.enabled": True, "robot.wheel_count": 4
        }  # fmt: skip
        assert snap["online"] is True
        assert all(p["last_change"]["via"] == "start" for p in snap["parameters"])
        types = {p["descriptor"]["type"] for p in snap["parameters"]}
        assert types == {"double", "string", "bool", "integer"}

    changes = [b for t, _, b in msgs if t == "/paramdds/changes"]
    rows = [(c["node"], c["name"], c["old"]["value"], c["new"]["value"], c["who"], c["via"]) for c in changes]
    robot1 = [r for r in rows if r[0] == "robot1"]
    robot2 = [r for r in rows if r[0] == "robot2"]
    assert robot1 == [
        ("robot1", "robot.max_velocity", 1.5, 2.5, "alice", "cli"),
        ("robot1", "robot.enabled", True, False, "carol", "cli"),
        ("robot1", "robot.max_velocity", 2.5, 3.0, "alice", "cli"),
    ]
    assert sorted(robot2) == [
        ("robot2", "robot.name", "my_robot", "bobs", "bob", "cli"),
        ("robot2", "robot.wheel_count", 4, 6, "bob", "cli"),
    ]
    assert [c["value"] for c in changes if c["node"] == "robot1"] == [2.5, 0, 3.0]  # what a Plot panel graphs
    revisions = [c["revision"] for c in changes if c["node"] == "robot1"]
    assert revisions == sorted(revisions) and len(set(revisions)) == 3
    assert all(c["source"] == "live" for c in changes)
    presence = [(b["node"], b["event"], b["online"]) for t, _, b in msgs if t == "/paramdds/presence"]
    assert presence == [("robot2", "offline", False)]
    assert not [b for t, _, b in msgs if t == "/paramdds/gaps"]
    # the recorded end state is each node's state
    for node in ("robot1", "robot2"):
        end = {p["name"]: p["value"]["value"] for p in snaps[node]["parameters"]}
        for c in changes:
            if c["node"] == node:
                end[c["name"]] = c["new"]["value"]
        assert end == now[node]

    # read back by the CLI, where no node runs: the same shapes as from the nodes
    done = cli(domain, "history", "robot1", "--from", str(path), "-o", "json")
    assert done.returncode == 0, done.stderr
    history = [(r["name"], r["old"], r["new"], r["who"], r["via"]) for r in json.loads(done.stdout)]
    assert history == [r[1:] for r in robot1]
    done = cli(domain, "history", "robot1", "robot.enabled", "--from", str(path))
    assert done.returncode == 0 and "robot.enabled: true → false  by carol (claimed) via cli" in done.stdout
    first = revisions[0]
    done = cli(domain, "diff", f"robot1@{first}", "robot1", "--from", str(path))
    assert done.returncode == 1, done.stderr  # they differ
    assert done.stdout.splitlines() == ["robot.enabled: true → false", "robot.max_velocity: 2.5 → 3.0"]
    done = cli(domain, "diff", "robot1@2000-01-01", "robot1", "--from", str(path))
    assert done.returncode == 1 and "does not reach node 'robot1'" in done.stderr
    done = cli(domain, "history", "ghost", "--from", str(path))
    assert done.returncode == 3 and done.stderr.count("\n") == 1, done.stderr


def test_kill_9_leaves_a_file_readable_up_to_the_last_2_seconds(nodes: int, tmp_path: Path) -> None:
    domain = nodes
    path = tmp_path / "killed.mcap"
    rec: Proc = start_recorder(domain, path)
    made: list[tuple[float, float]] = []  # (when the set returned, the value)
    try:
        for i in range(12):
            value = 10.0 + i
            set_as(domain, "alice", "robot1", f"robot.max_velocity={value}")
            made.append((time.monotonic(), value))
            time.sleep(0.25)
    finally:
        killed = rec.kill()
        rec.stop()
    got, error = stream_messages(path)
    assert error is not None or got  # a torn tail (or, by luck, a file that ends on a whole record)
    assert any(t == "/paramdds/snapshot" for t, _, _ in got)
    recorded = [b["new"]["value"] for t, _, b in got if t == "/paramdds/changes"]
    older = [v for when, v in made if when < killed - 2.0]
    assert older, "the test made no change more than 2 s before the kill"
    assert recorded[: len(older)] == older, (recorded, made, killed)
    done = cli(domain, "history", "robot1", "--from", str(path), "-o", "json")
    assert done.returncode == 0, done.stderr
    assert [r["new"] for r in json.loads(done.stdout)] == recorded
    assert done.stderr.startswith("paramdds: note: ") and "is not finished" in done.stderr
    assert done.stderr.count("\n") == 1


def test_a_stalled_recorder_fills_what_it_missed_from_history(nodes: int, tmp_path: Path) -> None:
    """SIGSTOP the recorder while a parameter changes ten times: its reader keeps only the
    newest sample, and the revisions between are read from the node's history."""
    domain = nodes
    path = tmp_path / "stalled.mcap"
    rec = start_recorder(domain, path, "robot1")
    try:
        rec.popen.send_signal(signal.SIGSTOP)
        try:
            for i in range(10):
                set_as(domain, "dave", "robot1", f"robot.max_velocity={20.0 + i}")
        finally:
            rec.popen.send_signal(signal.SIGCONT)
        time.sleep(2.0)
    finally:
        assert rec.stop() == 0, rec.stderr_text()
    msgs = messages(path)
    assert not [b for t, _, b in msgs if t == "/paramdds/gaps"]
    changes = [b for t, _, b in msgs if t == "/paramdds/changes"]
    assert [c["new"]["value"] for c in changes] == [20.0 + i for i in range(10)]
    assert [c["old"]["value"] for c in changes] == [1.5] + [20.0 + i for i in range(9)]
    assert {c["who"] for c in changes} == {"dave"}
    revisions = [c["revision"] for c in changes]
    assert revisions == list(range(revisions[0], revisions[0] + 10))
    sources = [c["source"] for c in changes]
    assert "history" in sources, sources  # the stall made the reader skip: filled from history
    assert all(t != "/paramdds/snapshot" or b["node"] == "robot1" for t, _, b in msgs)  # the glob


def test_split_by_time_starts_each_file_with_a_snapshot(nodes: int, tmp_path: Path) -> None:
    domain = nodes
    path = tmp_path / "split.mcap"
    rec = start_recorder(domain, path, "--split", "2s")
    try:
        assert rec.lines[-1][1].endswith("split-0001.mcap")
        for i in range(8):
            set_as(domain, "erin", "robot2", f"robot.wheel_count={10 + i}")
            time.sleep(0.4)
        rec.wait_for("split-0002.mcap", 10)
    finally:
        assert rec.stop() == 0, rec.stderr_text()
    parts = sorted(tmp_path.glob("split-*.mcap"))
    assert len(parts) >= 2 and not path.exists()
    seen = []
    for part in parts:
        msgs = messages(part)  # each part finished: summary and footer
        snaps = [b for t, _, b in msgs if t == "/paramdds/snapshot"]
        assert {s["node"] for s in snaps} == {"robot1", "robot2"}
        assert msgs[0][0] == "/paramdds/snapshot"
        (robot2,) = [s for s in snaps if s["node"] == "robot2"]
        wheels = {p["name"]: p["value"]["value"] for p in robot2["parameters"]}
        changes = [b["new"]["value"] for t, _, b in msgs if t == "/paramdds/changes"]
        # a part's snapshot holds the value the changes before it left
        assert wheels["robot.wheel_count"] == (seen[-1] if seen else 4)
        seen.extend(changes)
    assert seen == [10 + i for i in range(8)]


def test_a_restarted_node_is_presence_not_changes(nodes: int, tmp_path: Path) -> None:
    """A node stopped and started again with the same values: offline, restarted, online;
    its values, the same, are no change, and its revisions starting again are no gap."""
    domain = nodes
    path = tmp_path / "restart.mcap"
    rec = start_recorder(domain, path, "robot1")
    params = tmp_path / "params.yaml"
    try:
        SERVERS[domain]["robot1"].stop()
        time.sleep(1.0)
        SERVERS[domain]["robot1"] = start_server(domain, "-n", "robot1", "-p", str(params))
        time.sleep(1.5)
        set_as(domain, "gina", "robot1", "robot.wheel_count=8")
        time.sleep(1.0)
    finally:
        assert rec.stop() == 0, rec.stderr_text()
    msgs = messages(path)
    presence = [(b["node"], b["event"]) for t, _, b in msgs if t == "/paramdds/presence"]
    assert presence == [("robot1", "offline"), ("robot1", "restarted"), ("robot1", "online")], presence
    changes = [
        (b["name"], b["old"]["value"], b["new"]["value"], b["who"])
        for t, _, b in msgs
        if t == "/paramdds/changes"
    ]
    assert changes == [("robot.wheel_count", 4, 8, "gina")]
    assert not [b for t, _, b in msgs if t == "/paramdds/gaps"]
