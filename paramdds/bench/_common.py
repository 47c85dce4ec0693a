"""What every scenario shares: worker processes, statistics, output.

Workers
    Each server, echo or monitor runs in its own process, started as
    ``python -m paramdds.bench.worker ROLE --opts…`` in a new session (its own
    process group). A worker prints ``READY {json}`` on stdout when it is set up,
    may print ``RESULT {json}`` lines, and exits when its stdin closes (so a
    bench process that dies, even by SIGKILL, takes its workers with it) or on
    SIGTERM. :class:`Workers` closes stdin, waits briefly, then kills the whole
    process group: no orphans, also on Ctrl-C.

Statistics
    Percentiles by the nearest-rank method on the sorted samples; medians of
    repeated runs. Times are measured with ``time.perf_counter_ns``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import selectors
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

READY = "READY"
RESULT = "RESULT"
NODE_PREFIX = "bench_n"


def node_names(count: int, prefix: str = NODE_PREFIX) -> list[str]:
    return [f"{prefix}{i:04d}" for i in range(count)]


# -- statistics -------------------------------------------------------------------------


def percentile(values: Sequence[float], q: float) -> float:
    """Nearest-rank percentile (q in 0..100) of ``values``."""
    if not values:
        raise ValueError("no samples")
    ordered = sorted(values)
    rank = max(1, math.ceil(q / 100.0 * len(ordered)))
    return float(ordered[rank - 1])


class Latencies:
    """Many latencies in a fixed memory, for a process whose memory is what is measured:
    counts in buckets 1 % wide (log scale), so :meth:`percentile` is the nearest-rank
    percentile of what was added to within 1 %; the largest kept exactly. A list of floats
    grew the soak's prober by 1 MiB an hour (32,000 gets)."""

    STEP = math.log1p(0.01)
    FLOOR = 1e-6  # what is smaller falls in the first bucket

    def __init__(self) -> None:
        self.counts: dict[int, int] = {}
        self.n = 0
        self.max = 0.0

    def add(self, x: float) -> None:
        k = int(math.log(max(x, self.FLOOR) / self.FLOOR) / self.STEP)
        self.counts[k] = self.counts.get(k, 0) + 1
        self.n += 1
        self.max = max(self.max, x)

    def percentile(self, q: float) -> float:
        """The nearest-rank percentile (q in 0..100), as the middle of its bucket (never above the max)."""
        if not self.n:
            raise ValueError("no samples")
        rank = max(1, math.ceil(q / 100.0 * self.n))
        seen = 0
        for k in sorted(self.counts):
            seen += self.counts[k]
            if seen >= rank:
                return min(self.FLOOR * math.exp((k + 0.5) * self.STEP), self.max)
        return self.max


def median(values: Sequence[float]) -> float:
    ordered = sorted(values)
    n = len(ordered)
    if n == 0:
        raise ValueError("no samples")
    mid = n // 2
    return float(ordered[mid]) if n % 2 else (ordered[mid - 1] + ordered[mid]) / 2.0


def rss_mb(pid: int) -> float:
    """Resident set size of ``pid`` in MiB, from /proc/<pid>/status (VmRSS)."""
    with open(f"/proc/{pid}/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError(f"no VmRSS for pid {pid}")


# -- workers ----------------------------------------------------------------------------


class WorkerError(RuntimeError):
    pass


def worker_env(localhost: bool) -> dict[str, str]:
    env = dict(os.environ)
    if localhost:
        env["PARAMDDS_LOCALHOST"] = "1"
    env.setdefault("PYTHONUNBUFFERED", "1")
    return env


class Worker:
    """One worker process; see the module docstring for its protocol."""

    def __init__(
        self,
        role: str,
        args: Sequence[str],
        *,
        localhost: bool,
        domain: int,
        wrap: Sequence[str] = (),
        env: dict[str, str] | None = None,
        module: str = "paramdds.bench.worker",
        stderr_file: Path | None = None,
        name: str = "",
    ) -> None:
        """``wrap``: a command prefix (``ip netns exec NS``); ``env``: the environment (default
        :func:`worker_env`); ``module``: the worker's module (run as ``python -m``);
        ``stderr_file``: where its stderr goes (appended; default a pipe); ``name``: what
        errors call it (default ``role``)."""
        self.role = name or role
        self._err = stderr_file
        cmd = [*wrap, sys.executable, "-m", module, role, "-d", str(domain), *args]
        if localhost:
            cmd.append("--localhost")
        self.started_ns = time.perf_counter_ns()
        with contextlib.ExitStack() as files:
            err = subprocess.PIPE if stderr_file is None else files.enter_context(open(stderr_file, "a"))
            self.proc = subprocess.Popen(
                cmd,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=err,
                text=True,
                bufsize=1,
                start_new_session=True,
                env=worker_env(localhost) if env is None else env,
            )
        self._stderr_tail: list[str] = []

    @property
    def pid(self) -> int:
        return self.proc.pid

    def read(self, tag: str, timeout: float) -> dict[str, Any]:
        """Wait for the next ``TAG {json}`` line; WorkerError on exit or timeout."""
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout
        sel = selectors.DefaultSelector()
        sel.register(self.proc.stdout, selectors.EVENT_READ)
        try:
            while True:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise WorkerError(f"{self.role} worker: no {tag} line within {timeout:g} s{self._why()}")
                if not sel.select(remaining):
                    continue
                line = self.proc.stdout.readline()
                if not line:
                    self.proc.wait(timeout=5)
                    raise WorkerError(
                        f"{self.role} worker exited ({self.proc.returncode}) before {tag}{self._why()}"
                    )
                word, _, rest = line.strip().partition(" ")
                if word == tag:
                    data: dict[str, Any] = json.loads(rest) if rest else {}
                    data["_at_ns"] = time.perf_counter_ns()
                    return data
        finally:
            sel.close()

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def _why(self) -> str:
        err = self._read_stderr()
        return f"; stderr: {err[-800:]}" if err else ""

    def _read_stderr(self) -> str:
        if self._err is not None:
            with contextlib.suppress(OSError):
                return self._err.read_text(errors="replace").strip()
            return ""
        if self.proc.poll() is None or self.proc.stderr is None:
            return ""
        try:
            return self.proc.stderr.read().strip()
        except (OSError, ValueError):
            return ""

    def stop(self, grace: float = 5.0) -> int | None:
        """Close stdin (the worker exits cleanly), then kill the group if it lingers."""
        proc = self.proc
        if proc.poll() is None and proc.stdin is not None:
            with contextlib.suppress(OSError, ValueError):
                proc.stdin.close()
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=grace)
        _kill_group(proc.pid, signal.SIGTERM)
        if proc.poll() is None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=2.0)
        _kill_group(proc.pid, signal.SIGKILL)
        if proc.poll() is None:
            proc.wait()
        for stream in (proc.stdout, proc.stderr, proc.stdin):
            if stream is not None:
                with contextlib.suppress(OSError, ValueError):
                    stream.close()
        return proc.returncode


def _kill_group(pid: int, sig: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, sig)


class Workers:
    """The workers of one scenario; ``with Workers(...) as w`` stops them all on exit."""

    def __init__(self, *, localhost: bool, domain: int) -> None:
        self.localhost = localhost
        self.domain = domain
        self._all: list[Worker] = []

    def start(
        self,
        role: str,
        *args: str,
        domain: int | None = None,
        wrap: Sequence[str] = (),
        env: dict[str, str] | None = None,
    ) -> Worker:
        worker = Worker(
            role,
            list(args),
            localhost=self.localhost,
            domain=self.domain if domain is None else domain,
            wrap=wrap,
            env=env,
        )
        self._all.append(worker)
        return worker

    def stop(self, worker: Worker) -> int | None:
        if worker in self._all:
            self._all.remove(worker)
        return worker.stop()

    def close(self) -> None:
        while self._all:
            self._all.pop().stop()

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def start_timed(cmd: Sequence[str], *, env: dict[str, str]) -> tuple[subprocess.Popen[str], int]:
    """Start a command in a process group of its own; (the process, its start time in ns)."""
    t0 = time.perf_counter_ns()
    proc = subprocess.Popen(
        list(cmd),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    return proc, t0


def finish_timed(proc: subprocess.Popen[str], t0: int, *, timeout: float) -> tuple[float, str]:
    """Wait for a command of :func:`start_timed`; (wall time in ms, stdout). Raises on a
    non-zero exit; on a timeout (or any other exception) its whole process group is killed."""
    try:
        out, err = proc.communicate(timeout=timeout)
    except BaseException:
        _kill_group(proc.pid, signal.SIGKILL)
        proc.wait()
        raise
    elapsed = (time.perf_counter_ns() - t0) / 1e6
    if proc.returncode != 0:
        cmd = " ".join(map(str, proc.args)) if isinstance(proc.args, list) else str(proc.args)
        raise WorkerError(f"{cmd} exited {proc.returncode}: {err.strip()[-800:]}")
    return elapsed, out


def run_timed(cmd: Sequence[str], *, env: dict[str, str], timeout: float = 60.0) -> tuple[float, str]:
    """Run a command to completion; (wall time in ms, stdout). Raises on a non-zero exit."""
    proc, t0 = start_timed(cmd, env=env)
    return finish_timed(proc, t0, timeout=timeout)


# -- output -----------------------------------------------------------------------------


_LOOP_AT_START: list[float] = []


def python_loop_ms() -> float:
    """How fast this machine runs Python right now: the best of three 1M-step loops, in ms.

    Shared and virtual machines vary by a factor of several within minutes; printed
    beside every result (before and after the run) so runs can be compared fairly."""
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        total = 0
        for i in range(1_000_000):
            total += i
        best = min(best, (time.perf_counter() - t0) * 1e3)
    return round(best, 1)


def start_probe() -> None:
    _LOOP_AT_START[:] = [python_loop_ms()]


def emit(args: Any, data: dict[str, Any], table: str) -> None:
    loop = {"before": _LOOP_AT_START[0] if _LOOP_AT_START else None, "after": python_loop_ms()}
    if getattr(args, "output", "table") == "json":
        sys.stdout.write(json.dumps({**data, "python_loop_ms": loop}, indent=2, sort_keys=False) + "\n")
    else:
        sys.stdout.write(table.rstrip("\n") + "\n")
        sys.stdout.write(
            f"machine speed: a 1M-step Python loop took {loop['before']} ms before and {loop['after']} ms "
            "after this run (lower is faster)\n"
        )
    sys.stdout.flush()


def render(headers: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A plain text table (right-aligned numbers)."""
    cells = [[_cell(v) for v in row] for row in rows]
    widths = [len(h) for h in headers]
    for row in cells:
        widths = [max(w, len(c)) for w, c in zip(widths, row, strict=True)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    for row in cells:
        lines.append(
            "  ".join(c.rjust(w) if _numeric(c) else c.ljust(w) for c, w in zip(row, widths, strict=True))
        )
    return "\n".join(lines)


def _cell(v: object) -> str:
    if isinstance(v, float):
        return f"{v:,.1f}" if abs(v) < 1e5 else f"{v:,.0f}"
    return str(v)


def _numeric(c: str) -> bool:
    return c.replace(",", "").replace(".", "", 1).replace("x", "").lstrip("-").isdigit()


def note(message: str) -> None:
    """Progress on stderr (stdout is the result)."""
    sys.stderr.write(f"bench: {message}\n")
    sys.stderr.flush()


def alternate(systems: dict[str, tuple[Callable[[], None], int]], rounds: int) -> dict[str, list[float]]:
    """Time every call of each system, in microseconds, the systems taking turns.

    ``systems`` maps a name to ``(call, total)``; each of the ``rounds`` runs every system's
    share of its total, starting one system further each round, so that none always runs
    first (after another's warm caches, or during a burst of the machine's other work).
    """
    samples: dict[str, list[float]] = {name: [] for name in systems}
    order = list(systems)
    clock = time.perf_counter_ns
    for r in range(rounds):
        for name in order[r % len(order) :] + order[: r % len(order)]:
            fn, total = systems[name]
            count = total // rounds + (1 if r < total % rounds else 0)
            out = samples[name]
            for _ in range(count):
                t0 = clock()
                fn()
                out.append((clock() - t0) / 1e3)
    return samples
