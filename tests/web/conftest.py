"""Fixtures of the web console tests: one domain, two nodes and one console per module."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import pytest

from ..cli._support import Proc, next_domain, start_server
from ._support import CONSOLE_PARAMS, Console


@pytest.fixture(scope="module")
def domain() -> int:
    return next_domain()


@pytest.fixture(scope="module")
def servers(domain: int) -> Iterator[Proc]:
    """``arm`` and ``base``, each holding examples/console_params.yaml."""
    proc = start_server(domain, "-n", "arm", "-n", "base", "-p", str(CONSOLE_PARAMS))
    yield proc
    if proc.popen.poll() is None:
        proc.stop()


@pytest.fixture(scope="module")
def console(domain: int, servers: Proc) -> Iterator[Console]:
    c = Console(domain)
    try:
        wait_for_nodes(c.url, {"arm", "base"})
        yield c
    finally:
        c.stop()


def wait_for_nodes(url: str, nodes: set[str], params: int = 9, timeout: float = 15.0) -> None:
    """Until the console lists every node of ``nodes`` online with all its parameters."""
    import time

    deadline = time.monotonic() + timeout
    seen: dict[str, object] = {}
    while time.monotonic() < deadline:
        body = httpx.get(url + "api/nodes", timeout=5).json()
        seen = {n["node"]: n for n in body["nodes"]}
        if all(n in seen and seen[n]["online"] and seen[n]["parameters"] == params for n in nodes):  # type: ignore[index]
            return
        time.sleep(0.1)
    raise AssertionError(f"the console did not list {sorted(nodes)} in {timeout} s: {seen}")
