"""A write's deadline: the time after which its node must not apply it.

A set request carries ``deadline``: nanoseconds since the Unix epoch by the
caller's clock (0: none). The caller sets it a little before it stops waiting
(:func:`deadline_for`), so that an answer given at the deadline still reaches
it; the node checks it by its own clock at its commit point and refuses the whole
request with EXPIRED past it: the server runs the table's set inside
:func:`applying`, and :meth:`ParameterTable.set` calls :func:`check` with
:func:`current` under the table's lock, after validation and the callbacks,
right before the commit. (A context variable rather than an argument: a table
subclass that overrides ``set`` and calls ``super().set`` keeps working, and
the application's own sets, on other threads, have no deadline.) So a caller
that got no answer (OUTCOME_UNKNOWN) knows that, with synchronized clocks,
nothing is applied after its deadline: a ``get`` then shows the final outcome.
docs/reliability.md states what holds when the clocks differ.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from ..errors import ExpiredError

NO_DEADLINE = 0
MAX_ALLOWANCE = 0.2  # seconds kept between a request's deadline and the end of its caller's wait
_CURRENT: ContextVar[int] = ContextVar("paramdds_request_deadline", default=NO_DEADLINE)


@contextmanager
def applying(deadline: int) -> Iterator[None]:
    """Within this block (on this thread), a table's set refuses to commit past ``deadline``."""
    token = _CURRENT.set(deadline)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def current() -> int:
    """The deadline of the request being applied on this thread (0: none)."""
    return _CURRENT.get()


def allowance(timeout: float) -> float:
    """How long before the end of a wait of ``timeout`` seconds the request's deadline falls:
    the time an answer given at the deadline has to travel back."""
    return min(MAX_ALLOWANCE, timeout / 10)


def deadline_for(timeout: float, start_ns: int | None = None) -> int:
    """The deadline of a request sent at ``start_ns`` (now) by a caller that waits ``timeout`` s."""
    start = time.time_ns() if start_ns is None else start_ns
    return start + max(1, int((timeout - allowance(timeout)) * 1e9))


def remaining(deadline: int, now_ns: int | None = None) -> float | None:
    """Seconds left before ``deadline`` by this host's clock (negative once past); None: no deadline."""
    if deadline == NO_DEADLINE:
        return None
    now = time.time_ns() if now_ns is None else now_ns
    return (deadline - now) / 1e9


def check(deadline: int, now_ns: int | None = None) -> None:
    """Raise EXPIRED when this host's clock is past ``deadline`` (0: never)."""
    left = remaining(deadline, now_ns)
    if left is not None and left < 0:
        raise ExpiredError(
            f"not applied: it arrived {-left:.3f} s after its deadline by this host's clock "
            "(the caller had stopped waiting); are the two hosts' clocks in sync?"
        )
