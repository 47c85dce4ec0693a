"""Watching one node from a revision: its history after it, then its live changes, none missed or repeated.

:class:`ReplayWatch` first reads the node's changes after a revision from its history
(:meth:`~paramdds.dds.client.ParameterClient.history`), then follows a monitor's events
of that node (give :meth:`ReplayWatch.on_event` to a
:class:`~paramdds.dds.monitor.ParameterMonitor` as a callback). A live change past
what was delivered is read from history, on a thread of its own, by the seam's rule
(:mod:`paramdds.core.replay`): a revision a slow reader skipped is filled from history,
and one that history does not hold (retention dropped it) is delivered as a
:class:`~paramdds.core.replay.Gap`. What is delivered are the node's
:class:`~paramdds.core.history.HistoryRecord` s (who, via, old and new value), in
revision order, each once. A restart of the node (a new incarnation) starts the
revisions again from the new start's.

Create the monitor with :meth:`on_event` before :meth:`replay`: a change made while
history is read is then seen by both, and delivered once.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable, Sequence
from typing import Protocol

from ..core.history import HistoryRecord, Outcome
from ..core.history_pages import TimeArg
from ..core.monitor_events import EventKind, MonitorEvent
from ..core.replay import Gap, Seam
from ..core.replies import HistoryReply
from ..errors import ParamddsError

__all__ = ["FILL_TRIES", "FILL_WAIT", "HistorySource", "ReplayWatch"]

log = logging.getLogger(__name__)

FILL_TRIES = 5  # history reads for one live revision before it counts as lost
FILL_WAIT = 0.1  # seconds between them (a node records a change as it publishes it)

_CHANGES = (EventKind.ADDED, EventKind.MODIFIED, EventKind.DELETED)


class HistorySource(Protocol):
    """What reads a node's history: a :class:`~paramdds.dds.client.ParameterClient`, or Zenoh's."""

    def history(
        self,
        node: str,
        names: Sequence[str] = (),
        *,
        since_revision: int | None = None,
        since_time: TimeArg = None,
        until: TimeArg = None,
        who: str = "",
        outcome: Outcome = Outcome.ALL,
        timeout: float | None = None,
    ) -> HistoryReply: ...


class ReplayWatch:
    """One node's changes after revision ``since``: replayed from history, then live.

    ``deliver`` gets each record (or gap) in order: from the caller's thread in
    :meth:`replay`, then from this watch's thread.
    """

    def __init__(
        self,
        client: HistorySource,
        node: str,
        since: int,
        deliver: Callable[[HistoryRecord | Gap], None],
    ) -> None:
        self.node = node
        self._client = client
        self._deliver = deliver
        self._seam: Seam[HistoryRecord] = Seam(since)
        self._from_time: float | None = None  # after a restart: records of the new start only
        self._events: queue.Queue[MonitorEvent | None] = queue.Queue()
        self._thread = threading.Thread(target=self._run, name=f"paramdds-replay-{node}", daemon=True)

    def on_event(self, event: MonitorEvent) -> None:
        """The monitor's callback (any thread): this node's changes and restarts are queued."""
        if event.node == self.node and (event.event in _CHANGES or event.event is EventKind.RESTARTED):
            self._events.put(event)

    def replay(self) -> HistoryReply:
        """Deliver the node's changes after ``since`` from its history, then follow the live
        ones. Raises what the history call raises (the node is not there, keeps no history);
        the reply's ``compacted`` says retention dropped part of it (a gap is delivered)."""
        reply = self._read()
        for item in self._seam.history((r.revision, r) for r in reply.records):
            self._deliver(item)
        self._thread.start()
        return reply

    def close(self) -> None:
        """Stop following (the deliveries under way end first)."""
        self._events.put(None)
        if self._thread.is_alive():
            self._thread.join(5.0)

    def _read(self) -> HistoryReply:
        return self._client.history(
            self.node, since_revision=self._seam.top, since_time=self._from_time, outcome=Outcome.APPLIED
        )

    def _run(self) -> None:
        while True:
            event = self._events.get()
            if event is None:
                return
            if event.event is EventKind.RESTARTED:
                self._seam.reset(event.revision)
                self._from_time = event.stamp or None
            elif self._seam.live(event.revision):
                self._fill()

    def _fill(self) -> None:
        """Read history until it reaches the live revision seen, or give it up as a gap."""
        for attempt in range(FILL_TRIES):
            if attempt:
                time.sleep(FILL_WAIT)
            try:
                reply = self._read()
            except ParamddsError as exc:
                log.warning("reading the history of node %r failed: %s", self.node, exc)
                continue
            for item in self._seam.history((r.revision, r) for r in reply.records):
                self._deliver(item)
            if not self._seam.wanted:
                return
        for item in self._seam.skip():
            self._deliver(item)
