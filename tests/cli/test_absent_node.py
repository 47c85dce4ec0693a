"""On a healthy link, "not present" stays fast and says why; with nothing running, it waits out --timeout.

Whole-process times (Python start-up included) of fresh ``paramdds get`` runs on
loopback. The rule (``paramdds.dds.discovery``): a node never seen is absent once a
parameter server was found, every server has delivered its state and discovery has
been quiet for 0.5 s, which on loopback is about 0.6 s after the call starts.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from ._support import next_domain, run_cli, start_server


@pytest.fixture(scope="module")
def served() -> Iterator[int]:
    domain = next_domain()
    server = start_server(domain, "-n", "present")
    try:
        yield domain
    finally:
        server.stop()


def _timed(domain: int, *args: str) -> tuple[float, int, str]:
    started = time.monotonic()
    out = run_cli(domain, *args)
    return time.monotonic() - started, out.returncode, out.stderr


@pytest.mark.slow
def test_an_absent_node_is_reported_not_present_quickly(served: int) -> None:
    _, code, _ = _timed(served, "list", "present", "--timeout", "1")
    assert code == 0  # positive control: the same path reaches a node that is there
    took, code, err = _timed(served, "get", "ghost", "x", "--timeout", "1")
    assert code == 3
    assert "node 'ghost' is not present" in err and "discovery settled" in err
    assert took < 4.0


def test_a_long_timeout_does_not_slow_the_absent_answer(served: int) -> None:
    took, code, err = _timed(served, "get", "ghost", "x", "--timeout", "30")
    assert code == 3 and "not present" in err
    # decided by discovery, not by the 30 s the user allowed; the bound leaves room for a
    # loaded machine, where start-up and discovery both stretch (the quiet period grows with them)
    assert took < 10.0


@pytest.mark.slow
def test_with_nothing_running_the_answer_is_a_timeout_that_says_so() -> None:
    took, code, err = _timed(next_domain(), "get", "ghost", "x", "--timeout", "1")
    assert code == 3
    assert "not seen within 1 s: no parameter server discovered" in err
    assert took < 4.0


def test_a_set_to_a_node_never_announced_is_not_present_as_fast_as_a_get(served: int) -> None:
    get_took, code, err = _timed(served, "get", "ghost", "robot.max_velocity", "--timeout", "10")
    assert code == 3 and "not present" in err
    took, code, err = _timed(served, "set", "ghost", "robot.max_velocity=1.0", "--timeout", "10")
    # exit 3, not 5 (outcome unknown): the copies went only to servers not hosting it, and are
    # sent no more, so it cannot land; a half second more than get, for the last copy's way
    assert code == 3, (code, err)
    assert "node 'ghost' is not present" in err and "sent no more" in err
    assert took < get_took + 2.0 and took < 5.0, (took, get_took)
