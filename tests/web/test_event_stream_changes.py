"""The console's event stream after a stall and a restart of a real server: the log and the
rows carry only what changed, plus one ``restarted`` entry (the monitor's rules, which the
console inherits)."""

from __future__ import annotations

import json
import os
import queue
import signal
import threading
import time
from pathlib import Path

import httpx
import pytest

from ..cli._support import SEED_PARAMS, next_domain, start_server
from ._support import Console
from .conftest import wait_for_nodes


def read_stream(url: str, out: queue.Queue[tuple[str, dict[str, object]]], stop: threading.Event) -> None:
    with httpx.stream("GET", url + "api/events", params={"node": "robot1"}, timeout=30) as r:
        kind = ""
        for line in r.iter_lines():
            if stop.is_set():
                return
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: ") and kind:
                out.put((kind, json.loads(line[6:])))


def collect(
    q: queue.Queue[tuple[str, dict[str, object]]], until: str, limit: float = 15.0, settle: float = 1.5
) -> list[tuple[str, dict[str, object]]]:
    """Messages until a log entry of kind ``until`` (then ``settle`` seconds more)."""
    got: list[tuple[str, dict[str, object]]] = []
    deadline = time.monotonic() + limit
    while (left := deadline - time.monotonic()) > 0:
        try:
            kind, data = q.get(timeout=left)
        except queue.Empty:
            break
        got.append((kind, data))
        if until == kind or (kind == "log" and any(e["event"] == until for e in data["events"])):  # type: ignore[attr-defined]
            deadline = min(deadline, time.monotonic() + settle)
            until = "\0"
    assert until == "\0", f"no {until!r} within {limit} s: {got}"
    return got


@pytest.mark.slow
def test_the_stream_shows_only_changes_after_a_stall_and_a_restart(tmp_path: Path) -> None:
    domain = next_domain()
    params = tmp_path / "p.yaml"
    params.write_text(SEED_PARAMS)
    server = start_server(domain, "-n", "robot1", "-p", str(params))
    console = Console(domain)
    stop = threading.Event()
    q: queue.Queue[tuple[str, dict[str, object]]] = queue.Queue()
    try:
        wait_for_nodes(console.url, {"robot1"}, params=7)
        threading.Thread(target=read_stream, args=(console.url, q, stop), daemon=True).start()
        collect(q, "node", settle=0.5)

        os.kill(server.popen.pid, signal.SIGSTOP)
        time.sleep(2.0)  # past the 1 s lease: offline
        os.kill(server.popen.pid, signal.SIGCONT)
        got = collect(q, "online")
        server.stop()
        changed = tmp_path / "changed.yaml"
        changed.write_text(SEED_PARAMS.replace("value: 30", "value: 15"))
        server = start_server(domain, "-n", "robot1", "-p", str(changed))
        got += collect(q, "restarted")
        log = [(e["event"], e["name"]) for kind, d in got if kind == "log" for e in d["events"]]  # type: ignore[union-attr]
        assert [e for e in log if e[0] in ("modified", "added", "deleted")] == [
            ("modified", "sensor.rate_hz")
        ], log
        assert [e for e in log if e[0] == "restarted"] == [("restarted", "")], log
        rows = [r["name"] for kind, d in got if kind == "params" for r in d["rows"]]  # type: ignore[union-attr]
        assert rows == ["sensor.rate_hz"], got
    finally:
        stop.set()
        server.stop()
        console.stop()
