"""``paramdds bench record``: what ``paramdds record`` costs per change, against the change rate.

A server worker hosts ``--nodes`` node ids (default 10) with ``--params`` parameters (20)
and changes one double parameter per node, round-robin, from inside the process (as a
node's own code does), at each rate of ``--rates`` (default 10, 100, 1,000 changes per
second) for ``--seconds`` (default 5). For each rate (and once at rate 0, the idle
control) a fresh ``paramdds record -o FILE 'bench_n*'`` and, as the baseline, a
``paramdds watch -o json 'bench_n*'`` (the same monitor following the same changes,
printing each instead of writing MCAP) run beside the changes:

* ``CPU``: each process's utime + stime from /proc over the change window, in ms per
  second, and per change after the idle run's rate is taken off;
* ``bytes per change``: the finished file (the recorder stopped with SIGINT) minus the
  idle run's file, divided by the changes the file holds;
* ``recorded``: the changes read back from the file (``paramdds.formats.recording``) and
  the changes the watcher printed, against those the server made.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from ._common import Worker, Workers, emit, note, render
from .fleet import cpu_seconds
from .foxglove import ReadyProcess
from .worker import param_name

RECORD_READY = re.compile(r"^\[RECORD\] Recording (\d+) nodes? to (.+)$")
ANY_LINE = re.compile(r".*")
NODE_GLOB = "bench_n*"


class Feeder:
    """Sends ``NODE NAME VALUE`` lines to a ``server --changes`` worker and counts its
    ``CHANGED`` answers in a thread (so its stdout never fills)."""

    def __init__(self, server: Worker, nodes: int) -> None:
        self.server = server
        self.nodes = nodes
        self.changed = 0
        self.refused = 0
        self._sent = 0
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        assert self.server.proc.stdout is not None
        for line in self.server.proc.stdout:
            if line.startswith("CHANGED"):
                if '"ok": true' in line:
                    self.changed += 1
                else:
                    self.refused += 1

    def paced(self, rate: int, seconds: float) -> tuple[int, float]:
        """``rate`` changes per second, ``rate * seconds`` in all (the last ones sent at once
        if this process fell behind); (changes sent, seconds taken)."""
        name = param_name(0)
        batch = max(1, rate // 100)
        total = int(seconds * rate)
        sent = 0
        start = time.monotonic()
        while sent < total:
            elapsed = time.monotonic() - start
            due = total if elapsed >= seconds else min(int(elapsed * rate) + batch, total)
            lines = []
            while sent < due:
                i = self._sent
                lines.append(f"bench_n{i % self.nodes:04d} {name} {(i % 100_000) * 0.01 + 0.005:.3f}")
                self._sent += 1
                sent += 1
            if lines:
                self.server.send("\n".join(lines))
            if sent < total:
                time.sleep(0.01)
        return sent, time.monotonic() - start

    def wait_answered(self, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while self.changed + self.refused < self._sent and time.monotonic() < deadline:
            time.sleep(0.01)


class Watcher:
    """``paramdds watch -o json``: waits for its ``synced`` line, then counts change lines."""

    def __init__(self, domain: int, localhost: bool) -> None:
        cmd = [sys.executable, "-m", "paramdds.cli", "watch", "-o", "json", "-d", str(domain), NODE_GLOB]
        self.proc = ReadyProcess(
            [*cmd, "--localhost"] if localhost else cmd, ANY_LINE, localhost=localhost, timeout=60
        )
        while '"synced"' not in self.proc.readline(60):
            pass
        self.modified = 0
        threading.Thread(target=self._drain, daemon=True).start()

    def settle(self, quiet: float) -> None:
        """Wait until no change line came for 0.5 s (at most ``quiet`` seconds)."""
        deadline = time.monotonic() + quiet
        last = -1
        while self.modified != last and time.monotonic() < deadline:
            last = self.modified
            time.sleep(0.5)

    def _drain(self) -> None:
        stdout = self.proc.proc.stdout
        assert stdout is not None
        try:
            for line in stdout:
                self.modified += '"modified"' in line
        except (OSError, ValueError):
            pass


def run(args: argparse.Namespace) -> int:
    quick = args.quick
    rates = args.rates or ([20, 100] if quick else [10, 100, 1000])
    seconds = args.seconds or (1.0 if quick else 5.0)
    nodes = args.nodes[0] if args.nodes else 10
    params = args.params or 20
    rows: list[dict[str, Any]] = []
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        server = workers.start("server", "--nodes", str(nodes), "--params", str(params), "--changes")
        server.read("READY", 60)
        feeder = Feeder(server, nodes)
        with tempfile.TemporaryDirectory(prefix="paramdds-bench-record-") as tmpdir:
            for rate in [0, *rates]:
                note(f"record: {rate} changes/s for {seconds:g} s")
                rows.append(measure(Path(tmpdir) / f"rate{rate}.mcap", feeder, rate, seconds, args))
    idle = rows.pop(0)
    for row in rows:
        extra_cpu = {
            k: row[f"{k}_cpu_ms"] - idle[f"{k}_cpu_ms"] / idle["seconds"] * row["seconds"]
            for k in ("record", "watch")
        }
        row["record_us_per_change"] = (
            round(extra_cpu["record"] * 1e3 / row["changes"], 1) if row["changes"] else None
        )
        row["watch_us_per_change"] = (
            round(extra_cpu["watch"] * 1e3 / row["changes"], 1) if row["changes"] else None
        )
        row["bytes_per_change"] = (
            round((row["file_bytes"] - idle["file_bytes"]) / row["recorded"], 1) if row["recorded"] else None
        )
    data = {"nodes": nodes, "params_per_node": params, "seconds": seconds, "idle": idle, "rows": rows}
    emit(args, data, table(data))
    return 0


def measure(
    path: Path, feeder: Feeder, rate: int, seconds: float, args: argparse.Namespace
) -> dict[str, Any]:
    """One rate: a fresh recorder and watcher, ``rate`` changes per second for ``seconds``."""
    from ..formats.recording import read_recording

    cmd = [sys.executable, "-m", "paramdds.cli", "record", "-o", str(path), "-d", str(args.domain), NODE_GLOB]
    recorder = ReadyProcess(
        [*cmd, "--localhost"] if args.localhost else cmd, RECORD_READY, localhost=args.localhost, timeout=60
    )
    try:
        watcher = Watcher(args.domain, args.localhost)
        try:
            time.sleep(0.5)  # both have settled after their start
            before = feeder.changed
            cpu0 = {"record": cpu_seconds(recorder.pid), "watch": cpu_seconds(watcher.proc.pid)}
            t0 = time.monotonic()
            sent_total, fed = feeder.paced(rate, seconds) if rate else (0, _idle(seconds))
            feeder.wait_answered(10.0)
            watcher.settle(3.0)  # the last changes reach both (the watcher's lines show it)
            took = time.monotonic() - t0
            cpu = {
                k: (cpu_seconds(p) - cpu0[k]) * 1e3
                for k, p in (("record", recorder.pid), ("watch", watcher.proc.pid))
            }
            changes = feeder.changed - before
            watched = watcher.modified
        finally:
            watcher.proc.close()
    finally:
        code = recorder.close()
    if code != 0:
        raise RuntimeError(f"paramdds record exited {code} on SIGINT")
    recording = read_recording(str(path))
    return {
        "rate": rate,
        "seconds": round(took, 2),
        "sent": sent_total,
        "changes": changes,
        "achieved_rate": round(changes / fed, 1),
        "recorded": len(recording.changes),
        "watched": watched,
        "record_cpu_ms": round(cpu["record"], 1),
        "watch_cpu_ms": round(cpu["watch"], 1),
        "record_cpu_ms_per_s": round(cpu["record"] / took, 1),
        "watch_cpu_ms_per_s": round(cpu["watch"] / took, 1),
        "file_bytes": path.stat().st_size,
    }


def _idle(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def table(data: dict[str, Any]) -> str:
    heads = [
        "changes/s",
        "made",
        "recorded / watched",
        "record CPU ms/s",
        "watch CPU ms/s",
        "µs per change (record / watch)",
        "bytes per change",
        "ratio CPU",
    ]
    idle = data["idle"]
    body: list[list[object]] = [
        [
            "0 (idle)",
            0,
            "-",
            idle["record_cpu_ms_per_s"],
            idle["watch_cpu_ms_per_s"],
            "-",
            f"file {idle['file_bytes']:,} B",
            "-",
        ]
    ]
    for r in data["rows"]:
        ratio = r["record_cpu_ms_per_s"] / r["watch_cpu_ms_per_s"] if r["watch_cpu_ms_per_s"] else 0
        body.append(
            [
                f"{r['rate']} (got {r['achieved_rate']:g})",
                r["changes"],
                f"{r['recorded']} / {r['watched']}",
                r["record_cpu_ms_per_s"],
                r["watch_cpu_ms_per_s"],
                f"{r['record_us_per_change']} / {r['watch_us_per_change']}",
                r["bytes_per_change"],
                f"{ratio:.2f}x",
            ]
        )
    head = (
        f"paramdds record vs paramdds watch (the same changes): {data['nodes']} nodes x "
        f"{data['params_per_node']} params, {data['seconds']:g} s per rate; CPU from /proc (utime + stime)"
    )
    return head + "\n" + render(heads, body)
