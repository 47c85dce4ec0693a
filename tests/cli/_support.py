"""Helpers for driving ``paramdds`` as a user would: real processes on loopback.

Every server and command runs as a subprocess with ``PARAMDDS_LOCALHOST=1`` and
a domain id of its own (a per-run random base plus a counter), so parallel and
repeated runs never see each other. Nothing here mocks DDS.
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path

from ..conftest import TEST_URI, next_domain_id

ROOT = Path(__file__).resolve().parents[2]
PARAMDDS = str(Path(sys.executable).with_name("paramdds"))


SEED_PARAMS = """\
parameters:
  - name: "robot.max_velocity"
    type: "double"
    value: 1.5
  - name: "robot.max_acceleration"
    type: "double"
    value: 0.8
  - name: "robot.name"
    type: "string"
    value: "my_robot"
  - name: "robot.enabled"
    type: "bool"
    value: true
  - name: "robot.wheel_count"
    type: "integer"
    value: 4
  - name: "sensor.rate_hz"
    type: "integer"
    value: 30
  - name: "sensor.frame_ids"
    type: "string_array"
    value: ["base", "laser"]
"""


def next_domain() -> int:
    """A domain id of its own, from the suite's one counter (tests/conftest.py)."""
    return next_domain_id()


def cli_env(domain: int) -> dict[str, str]:
    env = dict(os.environ)
    env["CYCLONEDDS_URI"] = TEST_URI  # this run's discovery tag (tests/conftest.py)
    env.update(PARAMDDS_LOCALHOST="1", PARAMDDS_DOMAIN=str(domain), PYTHONUNBUFFERED="1")
    return env


def run_cli(
    domain: int, *args: str, timeout: float = 30.0, stdin: str | None = None
) -> subprocess.CompletedProcess[str]:
    """``paramdds ARGS`` to completion; returns stdout, stderr and the exit code."""
    return subprocess.run(
        [PARAMDDS, *args], env=cli_env(domain), capture_output=True, text=True, timeout=timeout, input=stdin
    )


class Proc:
    """A long-running ``paramdds`` process whose stdout lines are collected as they come."""

    def __init__(self, domain: int, args: Sequence[str], *, cwd: Path | None = None) -> None:
        self.args = list(args)
        self.popen = subprocess.Popen(
            [PARAMDDS, *args],
            env=cli_env(domain),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=cwd,
        )
        self.lines: list[str] = []
        self.err = ""
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def wait_for(self, predicate: str, timeout: float = 15.0) -> str:
        """The first new stdout line containing ``predicate`` (fails the test on timeout or exit)."""
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"no line with {predicate!r} in {timeout} s; got {self.lines!r}")
            try:
                line = self._queue.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                self.popen.wait()
                err = self.stderr()
                raise AssertionError(
                    f"process ended ({self.popen.wait()}) before {predicate!r}: {self.lines!r} {err!r}"
                )
            self.lines.append(line)
            if predicate in line:
                return line

    def drain(self, settle: float = 0.3) -> list[str]:
        """Lines that arrive within ``settle`` seconds of quiet."""
        got = []
        while True:
            try:
                line = self._queue.get(timeout=settle)
            except queue.Empty:
                return got
            if line is None:
                return got
            self.lines.append(line)
            got.append(line)

    def stop(self, sig: int = signal.SIGTERM, timeout: float = 10.0) -> int:
        """Send ``sig`` (if still running), wait, close the pipes; the exit code."""
        if self.popen.poll() is None:
            self.popen.send_signal(sig)
        return self.wait(timeout, why=f"of signal {sig}")

    def wait(self, timeout: float, why: str = "") -> int:
        """The exit code once it ends by itself within ``timeout`` s (else killed, the test failed)."""
        try:
            code = self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait()
            self._close()
            raise AssertionError(f"{self.args} did not stop within {timeout} s {why}".strip()) from None
        self._close()
        return code

    def _close(self) -> None:
        self._reader.join(5.0)
        if self.popen.stderr is not None and not self.popen.stderr.closed:
            self.err = self.popen.stderr.read()
            self.popen.stderr.close()
        if self.popen.stdout is not None:
            self.popen.stdout.close()

    def stderr(self) -> str:
        """Everything the process wrote on stderr (after :meth:`stop`)."""
        if self.popen.poll() is not None and not self.err:
            self._close()
        return self.err


def start_server(domain: int, *args: str) -> Proc:
    """``paramdds server ARGS``, returned once it serves every node (or failing the test)."""
    proc = Proc(domain, ["server", *args])
    nodes = max(1, sum(1 for a in args if a in ("-n", "--node-name")))
    for _ in range(nodes):
        proc.wait_for("[SERVER] Serving node")
    return proc
