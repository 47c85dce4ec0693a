"""Fixtures for the Zenoh tests: a Python router session, sites (servers + a gateway), remote sessions.

Everything here is real: ``paramdds server`` and ``paramdds zenoh`` processes on DDS
domains of their own (the ``domain_id`` counter), a Zenoh router session in the test
process on a free loopback port, and remote Zenoh client sessions. Nothing leaves
loopback (the namespace tests make their own addresses, see ``netns.py``).
"""

from __future__ import annotations

import os
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from ..conftest import next_domain_id
from ..reliability.conftest import PARAMDDS, Proc, make_dds_env

pytest.importorskip("zenoh", reason="the zenoh extra is not installed (pip install -e '.[zenoh]')")

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PARAMS = str(EXAMPLES / "params.yaml")
SPEC = str(EXAMPLES / "robot_spec.yaml")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def in_ci() -> bool:
    return os.environ.get("CI", "").lower() == "true"


def open_router(endpoint: str) -> Any:
    from paramdds.zenoh.config import open_session, router_options

    return open_session(router_options([endpoint]))


def open_remote(endpoint: str, timeout: float = 5.0) -> Any:
    from paramdds.zenoh.config import ZenohOptions, open_session

    return open_session(ZenohOptions(connect=[endpoint], open_timeout=timeout))


class Fleet:
    """Sites on loopback, each a DDS domain of its own with servers and gateways, and one router."""

    def __init__(self, procs: list[Proc]) -> None:
        self.procs = procs
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.router = open_router(self.endpoint)
        self.domains: dict[str, int] = {}
        self.sessions: list[Any] = []

    def domain(self, site: str) -> int:
        if site not in self.domains:
            self.domains[site] = next_domain_id()
        return self.domains[site]

    def server(self, site: str, *nodes: str, spec: bool = True, extra: tuple[str, ...] = ()) -> Proc:
        argv = [PARAMDDS, "server", "-p", PARAMS, *extra]
        if spec:
            argv += ["--spec", SPEC]
        for n in nodes:
            argv += ["-n", n]
        proc = Proc(argv, make_dds_env(self.domain(site)))
        self.procs.append(proc)
        for _ in nodes:
            proc.wait_for("[SERVER] Serving node", 20)
        return proc

    def gateway(self, site: str, *extra: str) -> Proc:
        argv = [PARAMDDS, "zenoh", "--site", site, "--connect", self.endpoint, *extra]
        proc = Proc(argv, make_dds_env(self.domain(site)))
        self.procs.append(proc)
        proc.wait_for("[ZENOH] Gateway for site", 20)
        return proc

    def remote(self) -> Any:
        session = open_remote(self.endpoint)
        self.sessions.append(session)
        return session

    def close(self) -> None:
        for proc in self.procs:
            proc.stop()
        for session in self.sessions:
            session.close()
        self.router.close()


@pytest.fixture
def procs() -> Iterator[list[Proc]]:
    """Subprocesses a test starts; stopped (SIGTERM, then SIGKILL) at its end."""
    started: list[Proc] = []
    yield started
    for proc in reversed(started):
        proc.stop()


def wait_for(predicate: Callable[[], bool], timeout: float, step: float = 0.02) -> bool:
    import time

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


def holds_online(monitor: Any, names: list[str], timeout: float) -> bool:
    """Wait until ``monitor`` holds every one of ``names`` complete and online."""
    return bool(
        monitor.wait_until(
            lambda states: all(n in states and states[n].complete and states[n].online for n in names),
            timeout,
        )
    )
