"""Shared fixtures for tests that use real Cyclone DDS.

Isolation: every test that asks for ``domain_id`` gets a DDS domain id of its
own, from a counter whose start is derived from this pytest process's pid, so
repeated and parallel runs on one host do not meet. Cyclone's default port
mapping allows domain ids up to 232; we use 100..230 and wrap. Under pytest-xdist
(``-n 2``, the fast loop) each worker takes every n-th id of that range, none
another worker takes.

``PARAMDDS_LOCALHOST=1`` is set for the whole session (and so inherited by
every subprocess): nothing a test starts talks to the LAN or depends on
multicast.

On top of that, ``CYCLONEDDS_URI`` gets a discovery tag unique to this pytest
process (:data:`TEST_URI`, inherited by every subprocess): two runs on one host
(two checkouts, two developers, CI beside a benchmark) never discover each other
even when their domain counters meet. A test that talks to a peer that knows no
tags (Fast DDS) builds its environment without it (:func:`untagged_env`).
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from .zenoh.conftest import Fleet

os.environ["PARAMDDS_LOCALHOST"] = "1"
# A shell starts a background job (`&`, nohup) with SIGINT ignored, and an ignored signal
# stays ignored across exec: every program a test starts would then ignore the Ctrl-C the
# test sends it. A handler of ours is reset to the default in each child instead.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
TEST_TAG = f"paramdds-test-{os.getpid()}"
TEST_URI = f'<CycloneDDS><Domain id="any"><Discovery><Tag>{TEST_TAG}</Tag></Discovery></Domain></CycloneDDS>'
os.environ["CYCLONEDDS_URI"] = TEST_URI

DOMAIN_FIRST = 100
DOMAIN_LAST = 230


class _DomainCounter:
    """Hands out domain ids DOMAIN_FIRST..DOMAIN_LAST, starting at a pid-derived offset; under
    pytest-xdist, worker ``k`` of ``n`` only DOMAIN_FIRST + k, + k + n, …, so no two workers of a
    run ever hold one id at once (peers without discovery tags, Fast DDS, rely on that)."""

    def __init__(self, seed: int, worker: int = 0, workers: int = 1) -> None:
        self._ids = range(DOMAIN_FIRST + worker, DOMAIN_LAST + 1, workers)
        self._next = seed % len(self._ids)
        self._lock = threading.Lock()

    def take(self) -> int:
        with self._lock:
            value = self._ids[self._next]
            self._next = (self._next + 1) % len(self._ids)
        return value


def _xdist_worker() -> tuple[int, int]:
    """(this worker's index, the number of workers); (0, 1) outside pytest-xdist."""
    name = os.environ.get("PYTEST_XDIST_WORKER", "")  # "gw0", "gw1", ...
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    return (int(name[2:]), count) if name.startswith("gw") and count > 1 else (0, 1)


# Multiplying the pid by a number coprime to the span spreads neighbouring pids apart.
_domains = _DomainCounter(os.getpid() * 37, *_xdist_worker())


def next_domain_id() -> int:
    """A fresh domain id (for code that needs more than one per test)."""
    return _domains.take()


@pytest.fixture
def domain_id() -> int:
    """A DDS domain id no other test of this run uses at the same time."""
    return _domains.take()


def make_dds_env(domain_id: int, **extra: str) -> dict[str, str]:
    """Environment for a paramdds subprocess on ``domain_id``, loopback only."""
    env = dict(os.environ)
    env["PARAMDDS_DOMAIN"] = str(domain_id)
    env["PARAMDDS_LOCALHOST"] = "1"
    env["CYCLONEDDS_URI"] = TEST_URI
    env.update(extra)
    return env


@pytest.fixture
def fleet() -> Iterator[Fleet]:
    """Sites on loopback behind one Zenoh router (:class:`tests.zenoh.conftest.Fleet`), stopped at
    the end; skips without the zenoh extra."""
    from .zenoh.conftest import Fleet

    f = Fleet([])
    try:
        yield f
    finally:
        f.close()


@pytest.fixture
def dds_env() -> Callable[..., dict[str, str]]:
    """``dds_env(domain_id, **extra)`` -> environment dict for a subprocess."""
    return make_dds_env


def untagged_env(env: dict[str, str]) -> dict[str, str]:
    """``env`` without this run's discovery tag, for peers that cannot match tags."""
    out = dict(env)
    out.pop("CYCLONEDDS_URI", None)
    return out
