"""The soak bench's processes: programs started with their output in files, what /proc says
of a process (RSS, threads, open descriptors, and its C heap when it writes it down), and a
reader of the web console's live stream.

Every program runs in a process group of its own and dies with the bench (``PR_SET_PDEATHSIG``),
so a bench killed with SIGKILL leaves nothing answering on its domain.
"""

from __future__ import annotations

import contextlib
import ctypes
import http.client
import json
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.parse
from pathlib import Path
from typing import Any

from ._common import WorkerError

# ``python -c _DYING MODULE ARGS…``: run MODULE as ``python -m`` would, ended by SIGTERM when the
# bench (its parent) dies; its C heap written down as :func:`heap_probe` does
_DYING = (
    "import ctypes, runpy, signal, sys\n"
    "try:\n"
    "    ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG\n"
    "except (OSError, AttributeError):\n"
    "    pass\n"
    "from paramdds.bench._soak_procs import heap_probe\n"
    "heap_probe()\n"
    "module = sys.argv[1]\n"
    "sys.argv = [module, *sys.argv[2:]]\n"
    "runpy.run_module(module, run_name='__main__', alter_sys=True)\n"
)


HEAP_DIR_ENV = "PARAMDDS_SOAK_HEAP"  # where a soak's process writes its C heap (see heap_probe)
HEAP_EVERY = 5.0  # seconds between two writes of it


class _MallInfo2(ctypes.Structure):
    _fields_ = [(f, ctypes.c_size_t) for f in
                ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
                 "fordblks", "keepcost")]  # fmt: skip


def c_heap_mb() -> dict[str, float] | None:
    """This process's C heap (glibc's ``mallinfo2``, every arena), MiB: ``used`` (handed out
    and not freed, mmapped blocks included) and ``free`` (freed, kept by the allocator). None
    off glibc (or before 2.33)."""
    try:
        fn = ctypes.CDLL(None).mallinfo2
    except (OSError, AttributeError):
        return None
    fn.restype = _MallInfo2
    m = fn()
    return {"used": round((m.uordblks + m.hblkhd) / 2**20, 2), "free": round(m.fordblks / 2**20, 2)}


def heap_probe() -> None:
    """When :data:`HEAP_DIR_ENV` names a directory: a daemon thread writing this process's
    :func:`c_heap_mb` to ``<dir>/<pid>.json`` every :data:`HEAP_EVERY` seconds, which
    :func:`proc_stats` reads (what grows: memory in use, or memory the allocator keeps)."""
    directory = os.environ.get(HEAP_DIR_ENV)
    if not directory or c_heap_mb() is None:
        return
    path = Path(directory) / f"{os.getpid()}.json"

    def write() -> None:
        tmp = path.with_suffix(".tmp")
        while True:
            try:
                tmp.write_text(json.dumps(c_heap_mb()))
                tmp.replace(path)
            except OSError:  # the bench ended (its directory removed)
                return
            time.sleep(HEAP_EVERY)

    threading.Thread(target=write, name="soak-heap-probe", daemon=True).start()


class Proc:
    """A program (``python -m MODULE ARGV``) whose stdout and stderr go to files in ``logs``."""

    def __init__(
        self, name: str, module: str, argv: list[str], env: dict[str, str], logs: Path, *, stdin: bool = False
    ) -> None:
        self.name = name
        self.out = logs / f"{name}.out"
        self.err = logs / f"{name}.err"
        self._seen = self.out.stat().st_size if self.out.exists() else 0  # a restart appends
        with open(self.out, "a") as out, open(self.err, "a") as err:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", _DYING, module, *argv],
                stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
                stdout=out,
                stderr=err,
                text=True,
                env=env,
                start_new_session=True,
            )

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def wait_for(self, text: str, count: int = 1, timeout: float = 90.0) -> str:
        """Wait until this start's output holds ``text`` ``count`` times; the line of the last."""
        deadline = time.monotonic() + timeout
        while True:
            with open(self.out, errors="replace") as f:
                f.seek(self._seen)
                lines = [line for line in f.read().splitlines() if text in line]
            if len(lines) >= count:
                return lines[count - 1]
            if self.proc.poll() is not None or time.monotonic() > deadline:
                why = "exited" if self.proc.poll() is not None else f"no {text!r} within {timeout:g} s"
                raise WorkerError(f"{self.name}: {why}; stderr: {self.tail()}")
            time.sleep(0.05)

    def tail(self, chars: int = 800) -> str:
        with contextlib.suppress(OSError):
            return self.err.read_text(errors="replace")[-chars:].strip()
        return ""

    def send(self, line: str) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.write(line + "\n")
            self.proc.stdin.flush()

    def stop(self, *, kill: bool = False, grace: float = 15.0) -> None:
        """SIGKILL, or a clean stop (``quit`` on stdin if it has one, then SIGTERM); the group
        killed if it lingers."""
        if kill:
            _signal_group(self.proc.pid, signal.SIGKILL)
        elif self.proc.poll() is None:
            if self.proc.stdin is not None:  # "quit" first: a SIGINT during rclpy's shutdown hung it
                with contextlib.suppress(OSError, ValueError):
                    self.proc.stdin.write("quit\n")
                    self.proc.stdin.close()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self.proc.wait(timeout=grace / 2)
            self.proc.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=grace)
        _signal_group(self.proc.pid, signal.SIGKILL)
        self.proc.wait()
        if self.proc.stdin is not None:
            with contextlib.suppress(OSError, ValueError):
                self.proc.stdin.close()


def _signal_group(pid: int, sig: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, sig)


def proc_stats(pid: int, heap_dir: Path | None = None) -> dict[str, float] | None:
    """RSS (MiB), threads and open file descriptors of ``pid``, where its RSS lives (see
    :func:`_rss_by_mapping`) and, when it wrote them to ``heap_dir`` (:func:`heap_probe`), its
    C heap's MiB in use (``c_used_mb``) and freed but kept (``c_free_mb``); None when it is
    gone."""
    try:
        rss = threads = 0.0
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    rss = int(line.split()[1]) / 1024.0
                elif line.startswith("Threads:"):
                    threads = float(line.split()[1])
        fds = float(len(os.listdir(f"/proc/{pid}/fd")))
    except (FileNotFoundError, ProcessLookupError):
        return None
    return {
        "rss_mb": round(rss, 1),
        "threads": threads,
        "fds": fds,
        **_rss_by_mapping(pid),
        **_heap(pid, heap_dir),
    }


def _heap(pid: int, heap_dir: Path | None) -> dict[str, float]:
    try:
        heap = json.loads((heap_dir / f"{pid}.json").read_text()) if heap_dir is not None else None
    except (OSError, ValueError):
        return {}
    return {"c_used_mb": heap["used"], "c_free_mb": heap["free"]} if isinstance(heap, dict) else {}


def _rss_by_mapping(pid: int) -> dict[str, float]:
    """Where ``pid``'s RSS lives (MiB), to tell whose memory grows: ``brk_mb`` (the ``[heap]``
    mapping: the C allocator's main arena), ``arenas_1m_mb`` (anonymous mappings of exactly
    1 MiB: the Python object allocator's arenas), ``anon_mb`` (every other anonymous mapping:
    the C allocator's thread arenas and large blocks, Cyclone's threads' among them). Empty when
    ``smaps`` cannot be read."""
    out = {"brk_mb": 0.0, "arenas_1m_mb": 0.0, "anon_mb": 0.0}
    kind: str | None = None
    try:
        with open(f"/proc/{pid}/smaps", encoding="ascii", errors="replace") as f:
            for line in f:
                head = line.split(maxsplit=6)
                if "-" in head[0] and len(head) >= 5 and not head[0].endswith(":"):
                    start, end = (int(x, 16) for x in head[0].split("-"))
                    path = head[5].strip() if len(head) > 5 else ""
                    if path == "[heap]":
                        kind = "brk_mb"
                    elif path:
                        kind = None
                    else:
                        kind = "arenas_1m_mb" if end - start == 1 << 20 else "anon_mb"
                elif kind is not None and head[0] == "Rss:":
                    out[kind] += int(head[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        return {}
    return {k: round(v, 1) for k, v in out.items()}


class LiveStream:
    """One client of the console's live stream (``GET /api/events``, the page's EventSource):
    it counts the events by kind, and reconnects after a second (as a browser does) when the
    stream ends."""

    def __init__(self, url: str, node: str = "") -> None:
        parts = urllib.parse.urlsplit(url)
        self._host = parts.hostname or "127.0.0.1"
        self._port = parts.port or 80
        self._path = "/api/events" + (f"?{urllib.parse.urlencode({'node': node})}" if node else "")
        self.events: dict[str, int] = {}
        self.bytes = 0
        self.reconnects = 0
        self.last_error = ""
        self.last_at = time.monotonic()
        self._conn: http.client.HTTPConnection | None = None
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="soak-stream", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        first = True
        while not self._closed:
            if not first:
                self.reconnects += 1
                time.sleep(1.0)
            first = False
            try:
                self._read()
            except (OSError, http.client.HTTPException) as exc:
                self.last_error = f"{type(exc).__name__}: {exc}"

    def _read(self) -> None:
        conn = http.client.HTTPConnection(self._host, self._port, timeout=60)
        self._conn = conn
        try:
            conn.request("GET", self._path, headers={"Accept": "text/event-stream"})
            response = conn.getresponse()
            if response.status != 200:
                self.last_error = f"HTTP {response.status}"
                return
            while not self._closed:
                raw = response.readline()
                if not raw:
                    self.last_error = "the stream ended"
                    return
                self.bytes += len(raw)
                self.last_at = time.monotonic()
                line = raw.decode("utf-8", "replace")
                if line.startswith("event: "):
                    kind = line[7:].strip()
                    self.events[kind] = self.events.get(kind, 0) + 1
        finally:
            conn.close()

    def summary(self) -> dict[str, Any]:
        return {
            "events": dict(sorted(self.events.items())),
            "bytes": self.bytes,
            "reconnects": self.reconnects,
            "last_error": self.last_error,
            "quiet_s": round(time.monotonic() - self.last_at, 1),
        }

    def close(self) -> None:
        self._closed = True
        conn = self._conn
        if conn is not None and conn.sock is not None:
            with contextlib.suppress(OSError):
                conn.sock.shutdown(2)
        self._thread.join(timeout=5)
