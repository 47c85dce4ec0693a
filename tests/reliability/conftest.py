"""Helpers for the fault-injection tests: real processes, real Cyclone, real signals.

* :class:`Proc` runs a ``paramdds`` command as a subprocess and collects its stdout
  lines with the time each arrived (so a test can say *when* a line came).
* :func:`start_server` starts ``paramdds server`` and returns once it serves.
* the ``dds`` fixture hands out in-process participants, clients, monitors and
  servers on loopback and closes them all at the end of the test.

Every test gets its own domain id (``tests/conftest.py``), so runs do not meet.
"""

from __future__ import annotations

import contextlib
import gc
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from ..conftest import TEST_URI, next_domain_id

PARAMDDS = str(Path(sys.executable).with_name("paramdds"))

PARAMS_YAML = """\
parameters:
  - name: "robot.max_velocity"
    type: "double"
    value: 1.5
  - name: "robot.name"
    type: "string"
    value: "my_robot"
  - name: "robot.enabled"
    type: "bool"
    value: true
  - name: "robot.wheel_count"
    type: "integer"
    value: 4
  - name: "sensor.frame_ids"
    type: "string_array"
    value: ["base", "laser"]
"""
PARAM_NAMES = {"robot.max_velocity", "robot.name", "robot.enabled", "robot.wheel_count", "sensor.frame_ids"}


def make_dds_env(domain: int, **extra: str) -> dict[str, str]:
    """Environment for a paramdds subprocess on ``domain``, loopback only (as ``tests/conftest.py``)."""
    env = dict(os.environ)
    env["CYCLONEDDS_URI"] = TEST_URI  # this run's discovery tag (tests/conftest.py)
    env.update(PARAMDDS_DOMAIN=str(domain), PARAMDDS_LOCALHOST="1")
    env.update(extra)
    return env


def other_domain(domain: int) -> int:
    """A second domain id for a test that needs two: a fresh one from the shared counter.

    (``domain + 1`` would be the next test's domain, which then met this test's
    leftovers in the same process.)
    """
    fresh = next_domain_id()
    return fresh if fresh != domain else next_domain_id()


class Proc:
    """A long-running subprocess whose stdout lines are collected as ``(monotonic time, line)``."""

    def __init__(self, argv: Sequence[str], env: dict[str, str], *, cwd: Path | None = None) -> None:
        self.argv = list(argv)
        self.popen = subprocess.Popen(
            self.argv,
            env={**env, "PYTHONUNBUFFERED": "1"},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=cwd,
        )
        self.lines: list[tuple[float, str]] = []
        self._queue: queue.Queue[tuple[float, str] | None] = queue.Queue()
        self._err: list[str] = []
        self._threads = [
            threading.Thread(target=self._read, daemon=True),
            threading.Thread(target=self._read_err, daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    @property
    def pid(self) -> int:
        return self.popen.pid

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            self._queue.put((time.monotonic(), line.rstrip("\n")))
        self._queue.put(None)

    def _read_err(self) -> None:  # keep the pipe drained: a full pipe would block the child
        assert self.popen.stderr is not None
        for line in self.popen.stderr:
            self._err.append(line)

    def wait_for(self, predicate: str | Callable[[str], bool], timeout: float = 15.0) -> tuple[float, str]:
        """The first new stdout line matching ``predicate`` and when it came (fails on timeout/exit)."""
        test = predicate if callable(predicate) else (lambda line: predicate in line)
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(
                    f"no line matching {predicate!r} within {timeout} s from {self.argv[:3]}; "
                    f"got {[line for _, line in self.lines]!r}; stderr {self.stderr_text()!r}"
                )
            try:
                item = self._queue.get(timeout=remaining)
            except queue.Empty:
                continue
            if item is None:
                self._queue.put(None)
                raise AssertionError(
                    f"{self.argv[:3]} ended ({self.popen.wait()}) before a line matching {predicate!r}: "
                    f"{[line for _, line in self.lines]!r}; stderr {self.stderr_text()!r}"
                )
            self.lines.append(item)
            if test(item[1]):
                return item

    def stderr_text(self) -> str:
        return "".join(self._err)

    def kill(self) -> float:
        """SIGKILL; returns the monotonic time the signal was sent."""
        sent = time.monotonic()
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGKILL)
        self.popen.wait(10)
        return sent

    def stop(self, timeout: float = 10.0) -> int | None:
        """SIGTERM (SIGKILL after ``timeout``), then close the pipes; returns the exit code."""
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGTERM)
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()
        for thread in self._threads:
            thread.join(5)
        for pipe in (self.popen.stdout, self.popen.stderr):
            if pipe is not None:
                pipe.close()
        return self.popen.returncode


def paramdds_argv(*args: str) -> list[str]:
    return [PARAMDDS, *args]


def start_server(domain: int, *args: str, env: dict[str, str] | None = None, timeout: float = 20.0) -> Proc:
    """``paramdds server ARGS`` on ``domain`` (loopback), returned once every node is served."""
    proc = Proc(paramdds_argv("server", *args), env or make_dds_env(domain))
    nodes = max(1, sum(1 for a in args if a in ("-n", "--node-name")))
    for _ in range(nodes):
        proc.wait_for("[SERVER] Serving node", timeout)
    return proc


def vm_rss_kib(pid: int) -> int:
    """Resident set size of ``pid`` in KiB, from /proc/<pid>/status."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError(f"no VmRSS for pid {pid}")


@pytest.fixture
def params_file(tmp_path: Path) -> Path:
    path = tmp_path / "params.yaml"
    path.write_text(PARAMS_YAML)
    return path


@pytest.fixture
def procs() -> Iterator[list[Proc]]:
    """Subprocesses a test starts; whatever still runs at the end is stopped (SIGTERM, then SIGKILL)."""
    started: list[Proc] = []
    yield started
    for proc in started:
        proc.stop()


class DDS:
    """In-process DDS objects on loopback, closed (newest first) when the test ends."""

    def __init__(self) -> None:
        self._participants: dict[int, Any] = {}
        self._closers: list[Any] = []

    def participant(self, domain: int) -> Any:
        from paramdds.dds.participant import make_participant

        if domain not in self._participants:
            self._participants[domain] = make_participant(domain, localhost=True, app_name="reliability")
        return self._participants[domain]

    def own(self, obj: Any) -> Any:
        self._closers.append(obj)
        return obj

    def client(self, domain: int, **kwargs: Any) -> Any:
        from paramdds.dds.client import ParameterClient

        return self.own(ParameterClient(self.participant(domain), **kwargs))

    def monitor(self, domain: int, **kwargs: Any) -> Any:
        from paramdds.dds.monitor import ParameterMonitor

        return self.own(ParameterMonitor(self.participant(domain), **kwargs))

    def server(self, domain: int, *tables: Any) -> Any:
        from paramdds.dds.server import ParameterServer

        server = ParameterServer(self.participant(domain))
        for table in tables:
            server.add_node(table)
        return self.own(server.start())

    def close(self) -> None:
        while self._closers:
            obj = self._closers.pop()
            with contextlib.suppress(Exception):
                obj.close()
        # delete the participants (and every raw reader and writer a test made in them) now:
        # gc does not, and a TRANSIENT_LOCAL sample left behind would reach the next test
        # that gets this domain id when the counter wraps
        from paramdds.dds.participant import close_participant

        for participant in self._participants.values():
            with contextlib.suppress(Exception):
                close_participant(participant)
        self._participants.clear()
        gc.collect()


@pytest.fixture
def dds() -> Iterator[DDS]:
    holder = DDS()
    try:
        yield holder
    finally:
        holder.close()


def wait(predicate: Callable[[], bool], timeout: float, step: float = 0.01) -> bool:
    """Poll ``predicate`` until it holds or ``timeout`` seconds pass."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


__all__ = [
    "DDS",
    "PARAMDDS",
    "PARAMS_YAML",
    "PARAM_NAMES",
    "Proc",
    "make_dds_env",
    "other_domain",
    "paramdds_argv",
    "start_server",
    "vm_rss_kib",
    "wait",
]
