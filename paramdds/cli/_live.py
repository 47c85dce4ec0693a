"""Waiting, for the verbs that stay up until Ctrl-C and for those that need the current state."""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..dds.monitor import NodeState
    from ..session import Session

CURRENT_SETTLE = 2.0  # seconds current_states waits at most for the monitor to hold every node


def wait_until_interrupted(broken: threading.Event | None = None) -> None:
    """Block the main thread until Ctrl-C (KeyboardInterrupt) or SIGTERM (Terminated)."""
    while True:
        if broken is not None and broken.wait(1.0):
            raise BrokenPipeError("stdout was closed")
        if broken is None:
            time.sleep(3600)


def current_states(session: Session, nodes: list[str] | None = None) -> dict[str, NodeState]:
    """Every node (of ``nodes``: ids and globs) a fresh monitor holds once discovery has settled,
    or after at most :data:`CURRENT_SETTLE` s (``--timeout`` if shorter), with a warning."""
    import logging

    started = time.monotonic()
    monitor = session.monitor(nodes or None)
    if not monitor.settle(min(session.args.timeout, CURRENT_SETTLE), started=started):
        logging.getLogger(__name__).warning(
            "the node list may be incomplete: discovery did not settle in time"
        )
    return monitor.snapshot()
