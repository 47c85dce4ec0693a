"""Waiting, for the verbs that stay up until Ctrl-C and for those that need the current state."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..dds.monitor import NodeState, ParameterMonitor
    from ..session import Session

SETTLE = 0.5  # seconds a fresh watcher gives discovery before it calls the state complete
QUIET = 0.1  # seconds without events before the state counts as received
CURRENT_SETTLE = 2.0  # seconds current_states waits at most for the monitor to hold every node


def wait_until_interrupted(broken: threading.Event | None = None) -> None:
    """Block the main thread until Ctrl-C (KeyboardInterrupt) or SIGTERM (Terminated)."""
    while True:
        if broken is not None and broken.wait(1.0):
            raise BrokenPipeError("stdout was closed")
        if broken is None:
            time.sleep(3600)


def settle(monitor: ParameterMonitor, started: float, limit: float, quiet: Callable[[], float]) -> bool:
    """Wait (at most ``limit`` s from ``started``) until the monitor holds the current state.

    A fresh process cannot know when discovery is over, so besides the monitor's own
    sync it waits for at least :data:`SETTLE` seconds since start, then for every online
    node to be complete and :data:`QUIET` seconds without events (``quiet()`` returns
    the time of the last one). False when the limit was reached first.
    """
    deadline = started + limit
    monitor.wait_synced(limit)
    pause = started + SETTLE - time.monotonic()
    if pause > 0:
        time.sleep(pause)
    while True:
        remaining = deadline - time.monotonic()
        done = monitor.wait_until(
            lambda s: all(st.complete or not st.online for st in s.values()), max(0.0, remaining)
        )
        wait = quiet() + QUIET - time.monotonic()
        if wait <= 0 or remaining <= 0:
            return done and remaining > 0
        time.sleep(wait)


def current_states(session: Session, nodes: list[str] | None = None) -> dict[str, NodeState]:
    """Every node (of ``nodes``: ids and globs) a fresh monitor holds once discovery has settled,
    or after at most :data:`CURRENT_SETTLE` s (``--timeout`` if shorter), with a warning."""
    import logging

    last = [time.monotonic()]
    started = time.monotonic()
    monitor = session.monitor(nodes or None, on_event=lambda _e: last.__setitem__(0, time.monotonic()))
    if not settle(monitor, started, min(session.args.timeout, CURRENT_SETTLE), lambda: last[0]):
        logging.getLogger(__name__).warning(
            "the node list may be incomplete: discovery did not settle in time"
        )
    return monitor.snapshot()
