"""Helpers for the integration tests: real Cyclone DDS over loopback, never a mock.

* :class:`DdsSession` hands out in-process participants, servers, clients and
  monitors on one domain id and closes them all at the end of a test (then
  deletes the Domain, so nothing of one test lingers in the next).
* :class:`ServerProc` runs a :class:`~paramdds.dds.server.ParameterServer` in a
  subprocess (``sys.executable -c``): it prints ``READY`` once it serves and
  stops gracefully on SIGTERM (or dies on SIGKILL, for the offline tests).
* :func:`wait_until` waits for a condition with a deadline (for the few things
  no condition variable announces, e.g. a subprocess's output).
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from cyclonedds.core import Entity

from paramdds.core.table import ParameterTable
from paramdds.dds.client import ParameterClient
from paramdds.dds.monitor import ParameterMonitor
from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.server import ParameterServer


def wait_until(predicate: Callable[[], bool], timeout: float, interval: float = 0.01) -> bool:
    """True as soon as ``predicate()`` holds; False after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        if predicate():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(interval)


class DdsSession:
    """Everything one test creates on its domain, closed (newest first) by :meth:`close`."""

    def __init__(self, domain_id: int, *, topic_discovery: bool = False) -> None:
        self.domain_id = domain_id
        self.topic_discovery = topic_discovery
        self._closers: list[Any] = []
        self._participants: list[Any] = []

    def participant(self, app_name: str = "paramdds-test") -> Any:
        dp = make_participant(
            self.domain_id, localhost=True, app_name=app_name, topic_discovery=self.topic_discovery
        )
        self._participants.append(dp)
        return dp

    def server(self, *tables: ParameterTable, participant: Any = None) -> ParameterServer:
        server = ParameterServer(participant or self.participant("paramdds-test-server"))
        for table in tables:
            server.add_node(table)
        self._closers.append(server)
        return server.start()

    def client(self, participant: Any = None, **kwargs: Any) -> ParameterClient:
        client = ParameterClient(participant or self.participant("paramdds-test-client"), **kwargs)
        self._closers.append(client)
        return client

    def monitor(self, participant: Any = None, **kwargs: Any) -> ParameterMonitor:
        monitor = ParameterMonitor(participant or self.participant("paramdds-test-monitor"), **kwargs)
        self._closers.append(monitor)
        return monitor

    def close(self) -> None:
        while self._closers:
            self._closers.pop().close()
        domains = {id(d): d for d in (getattr(p, "domain", None) for p in self._participants) if d}
        for dp in self._participants:
            close_participant(dp)  # deletes the participant and every entity in it now, not at gc
        for domain in domains.values():
            Entity.__del__(domain)
        self._participants.clear()

    def __enter__(self) -> DdsSession:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- a server in another process ---------------------------------------------------------------

# Config (JSON in argv[1]): {"domain": int, "app_name": str, "topic_discovery": bool,
#   "nodes": [{"id": str, "param_list": path, "allow_undeclared": bool,
#              "params": {name: value}, "ranged": {name: [value, from, to]},
#              "read_only": {name: value}, "dynamic": {name: value}}]}
_SERVER_SCRIPT = r"""
import json, signal, sys
cfg = json.loads(sys.argv[1])
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})  # every thread inherits the mask
from paramdds.core.descriptors import IntegerRange, ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.formats.paramlist import load_param_list
from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.server import ParameterServer

dp = make_participant(cfg["domain"], localhost=True, app_name=cfg.get("app_name", "paramdds-test-server"),
                      topic_discovery=cfg.get("topic_discovery", False))
server = ParameterServer(dp)
for node in cfg["nodes"]:
    t = ParameterTable(node["id"], allow_undeclared=node.get("allow_undeclared", False))
    if node.get("param_list"):
        for p in load_param_list(node["param_list"]):
            t.declare(p.name, p.value)
    for name, value in node.get("params", {}).items():
        t.declare(name, value)
    for name, (value, lo, hi) in node.get("ranged", {}).items():
        t.declare(name, value, ParameterDescriptor(name, integer_range=IntegerRange(lo, hi, 0)))
    for name, value in node.get("read_only", {}).items():
        t.declare(name, value, ParameterDescriptor(name, read_only=True))
    for name, value in node.get("dynamic", {}).items():
        t.declare(name, value, ParameterDescriptor(name, dynamic_typing=True))
    server.add_node(t)
server.start()
print("READY", flush=True)
signal.sigwait({signal.SIGTERM})
server.close()
close_participant(dp)  # peers drop this participant now, not after its 10 s lease
print("CLOSED", flush=True)
"""


class ServerProc:
    """A ParameterServer in a subprocess; use as a context manager (it is killed at exit)."""

    def __init__(
        self,
        domain_id: int,
        nodes: Sequence[dict[str, Any]],
        *,
        topic_discovery: bool = False,
        app_name: str = "paramdds-test-server",
        ready_timeout: float = 15.0,
    ) -> None:
        config = {
            "domain": domain_id,
            "nodes": list(nodes),
            "topic_discovery": topic_discovery,
            "app_name": app_name,
        }
        env = dict(os.environ, PARAMDDS_LOCALHOST="1", PARAMDDS_DOMAIN=str(domain_id))
        self.proc = subprocess.Popen(
            [sys.executable, "-u", "-c", _SERVER_SCRIPT, json.dumps(config)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        self.pid = self.proc.pid
        self.lines: queue.Queue[str] = queue.Queue()
        self.stderr: list[str] = []
        assert self.proc.stdout is not None and self.proc.stderr is not None
        self._readers = [
            threading.Thread(target=self._pump, args=(self.proc.stdout, self.lines.put), daemon=True),
            threading.Thread(target=self._pump, args=(self.proc.stderr, self.stderr.append), daemon=True),
        ]
        for t in self._readers:
            t.start()
        try:
            self.expect("READY", ready_timeout)
        except BaseException:
            self.close()
            raise

    @staticmethod
    def _pump(stream: Any, sink: Callable[[str], None]) -> None:
        for line in stream:
            sink(line.rstrip("\n"))

    def expect(self, wanted: str, timeout: float) -> None:
        """Wait for the output line ``wanted``; AssertionError (with stderr) otherwise."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise AssertionError(
                    f"server subprocess did not print {wanted!r} within {timeout} s "
                    f"(exit code {self.proc.poll()}); stderr:\n" + "\n".join(self.stderr)
                ) from None
            if line == wanted:
                return

    def terminate(self, timeout: float = 10.0) -> int:
        """SIGTERM (graceful stop) and wait; the exit code."""
        self.proc.send_signal(signal.SIGTERM)
        return self.proc.wait(timeout)

    def freeze(self, timeout: float = 5.0) -> None:
        """SIGSTOP, and wait until every thread has stopped (the signal takes a moment)."""
        self.proc.send_signal(signal.SIGSTOP)
        assert wait_until(self._stopped, timeout), "the server process did not stop"

    def thaw(self) -> None:
        """SIGCONT: a frozen server runs on."""
        self.proc.send_signal(signal.SIGCONT)

    def _stopped(self) -> bool:
        tasks = f"/proc/{self.pid}/task"
        try:
            states = [self._state(f"{tasks}/{t}/stat") for t in os.listdir(tasks)]
        except OSError:
            return False
        return bool(states) and all(s in ("T", "t") for s in states)

    @staticmethod
    def _state(stat: str) -> str:
        with open(stat) as f:
            return f.read().rpartition(")")[2].split()[0]

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait(10.0)

    def close(self) -> None:
        """Graceful stop (a killed peer makes this process's writers linger on delete)."""
        if self.proc.poll() is None:
            try:
                self.terminate(timeout=5.0)
            except subprocess.TimeoutExpired:
                self.kill()
        for t in self._readers:
            t.join(5.0)
        for stream in (self.proc.stdout, self.proc.stderr):
            if stream is not None:
                stream.close()

    def __enter__(self) -> ServerProc:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
