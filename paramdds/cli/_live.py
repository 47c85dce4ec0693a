"""Waiting, for the verbs that stay up until Ctrl-C and for those that need the current state."""

from __future__ import annotations

import os
import select
import signal
import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..dds.monitor import NodeState
    from ..session import Session

CURRENT_SETTLE = 2.0  # seconds current_states waits at most for the monitor to hold every node


def wait_until_interrupted(broken: threading.Event | None = None) -> None:
    """Block the main thread until Ctrl-C (KeyboardInterrupt) or SIGTERM (Terminated), or
    until ``broken`` is set (BrokenPipeError).

    The kernel hands a process's signal to any thread that does not block it, and Python runs
    the handler in the main thread only when that thread next runs: asleep in ``time.sleep``
    it would never see a signal a worker thread took. So the main thread waits on a wakeup fd,
    which Python's C-level handler writes whichever thread the signal interrupted."""
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    previous = signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    try:
        while True:  # a signal's handler runs (and raises) as soon as select returns
            if select.select([read_end], [], [], None if broken is None else 1.0)[0]:
                os.read(read_end, 512)
            if broken is not None and broken.is_set():
                raise BrokenPipeError("stdout was closed")
    finally:
        signal.set_wakeup_fd(previous)
        os.close(read_end)
        os.close(write_end)


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
