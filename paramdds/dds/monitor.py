"""The monitor: every node's state and events, from a DDS reader or any other feed.

A :class:`ParameterMonitor` holds a :class:`~paramdds.core.state_book.StateBook` (each
node's state, the waits on it, the events) and the feed that fills it: made on a DDS
participant it reads ``ParameterEvents`` (:mod:`.monitor_feed`; the rules its events
follow are :mod:`.monitor_rules`'); made on a :class:`~paramdds.core.state_book.StateFeed` it
is fed by that (the Zenoh feed of :mod:`paramdds.zenoh.monitor`). Either way it offers
the same calls and events.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable

from cyclonedds.domain import DomainParticipant

from ..core.monitor_events import EventCallback, EventKind, MonitorEvent, NodeState
from ..core.names import NodeFilter
from ..core.results import LastChange
from ..core.state_book import StateBook, StateFeed
from .monitor_feed import QUIET, DdsStateFeed
from .qos import QosProfiles

__all__ = [
    "QUIET",
    "SETTLE",
    "EventCallback",
    "EventKind",
    "MonitorEvent",
    "NodeState",
    "ParameterMonitor",
    "StateFeed",
]

SETTLE = 0.5  # seconds a fresh monitor gives discovery before it calls the state complete


class ParameterMonitor:
    """Every node's state and events (``nodes``: ids and globs to keep; default all).

    ``participant``: a DDS participant, whose reader of ``ParameterEvents`` feeds the
    monitor (with the ``qos`` profiles; default the packaged ones), or any
    :class:`~paramdds.core.state_book.StateFeed` (then ``qos`` is not given).
    """

    def __init__(
        self,
        participant: DomainParticipant | StateFeed,
        qos: QosProfiles | None = None,
        *,
        nodes: NodeFilter | Iterable[str] | None = None,
        on_event: EventCallback | None = None,
    ) -> None:
        if isinstance(participant, DomainParticipant):
            feed: StateFeed = DdsStateFeed(participant, qos)
        elif qos is not None:
            raise TypeError("qos is the DDS feed's: give it with a participant, not with a feed")
        else:
            feed = participant
        self._book = StateBook(nodes=nodes, on_event=on_event)
        self._feed = feed
        feed.start(self._book)

    def add_callback(self, fn: EventCallback) -> None:
        self._book.add_callback(fn)

    def close(self) -> None:
        self._book.close()
        self._feed.close()

    def __enter__(self) -> ParameterMonitor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def snapshot(self) -> dict[str, NodeState]:
        """A copy of every node's state as this monitor holds it now."""
        return self._book.snapshot()

    def last_change(self, node: str, name: str) -> LastChange | None:
        """Who last changed parameter ``name`` of ``node`` (whether verified, through what,
        when, at which revision), as its state says; None when unknown (no such parameter, or
        its writer keeps no blame)."""
        return self._book.last_change(node, name)

    @property
    def synced(self) -> bool:
        return self._book.synced

    def wait_until(self, predicate: Callable[[dict[str, NodeState]], bool], timeout: float) -> bool:
        """Wait until ``predicate(states)`` holds (it sees the live dict; do not keep it)."""
        return self._book.wait_until(predicate, timeout)

    def wait_complete(self, nodes: Iterable[str], timeout: float) -> bool:
        """Wait until the full state of every node in ``nodes`` is here."""
        return self._book.wait_complete(nodes, timeout)

    def wait_synced(self, timeout: float) -> bool:
        return self._book.wait_synced(timeout)

    def settle(
        self, limit: float, *, started: float | None = None, stop: threading.Event | None = None
    ) -> bool:
        """Wait, at most ``limit`` s from ``started`` (``time.monotonic()``; default now), until
        this monitor holds the current state of every node there is: what a fresh process
        needs before it prints, records or serves "everything".

        A fresh process cannot know when discovery is over, so besides the feed's own sync
        it waits at least :data:`SETTLE` s from ``started``, then for every online node to be
        complete and :data:`QUIET` s without events. False when the limit came first, or
        ``stop`` was set (it also ends the wait).
        """
        begun = time.monotonic() if started is None else started
        deadline = begun + limit
        pause = stop.wait if stop is not None else time.sleep
        self.wait_synced(limit)
        pause(max(0.0, begun + SETTLE - time.monotonic()))
        while stop is None or not stop.is_set():
            remaining = deadline - time.monotonic()
            done = self.wait_until(
                lambda s: all(st.complete or not st.online for st in s.values()), max(0.0, remaining)
            )
            wait = self._book.last_event + QUIET - time.monotonic()
            if wait <= 0 or remaining <= 0:
                return done and remaining > 0
            pause(wait)
        return False
