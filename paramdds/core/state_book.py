"""The monitor's book: every node's state, the waits on it and the events, whatever feeds it.

A monitor is a :class:`StateBook` and a feed. The book knows no transport; a feed (any
object with the shape of :class:`StateFeed`: the DDS reader of ``ParameterEvents`` in
:mod:`paramdds.dds.monitor_feed`, the Zenoh subscriptions of :mod:`paramdds.zenoh.monitor`)
turns what its transport delivers into changes of the book, through these public calls only:

* ``with book.update() as u:`` runs the body under the book's lock. There the feed reads and
  changes node states (``u.get(node)``, ``u.node(node)`` makes one if needed; a
  :class:`NodeState` is plain data whose fields the feed sets) and its own book-keeping (the
  lock is held), and queues events (``u.emit``, or ``u.set_online`` / ``u.set_status``, which
  apply the online and status rules below and queue their event if there is one). When the
  body ends the waiters wake up and then, outside the lock, the callbacks get the events in
  the order queued. A body that raises changes what it changed but delivers nothing.
* ``book.wanted(node)``: whether the book keeps ``node`` (its ``nodes`` filter);
  ``book.has_callbacks``: whether events are worth making (a monitor's full state is 5,000+
  samples, and an event exists only to be delivered); ``book.synced``, ``book.closed``.
* ``book.mark_synced()``: the initial state is here (``synced`` is emitted, waits wake up).

The rules the book applies itself:

* online: a node's ``online`` changes → an ``online`` or ``offline`` event; going offline
  forgets the node's writer and second hosts (its last values are kept);
* status: an online node's status changes → a ``status`` event (going online or offline is
  an event of its own, which carries the status);
* an event never shows a revision lower than one shown before in the node's incarnation
  (:meth:`BookUpdate.shown`; a feed resets ``NodeState.shown`` on a new incarnation);
* a callback that raises is logged and costs neither the other callbacks nor the rest of
  the events.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from typing import Protocol

from .monitor_events import EventCallback, EventKind, MonitorEvent, NodeState
from .names import NodeFilter, canonical_node_id
from .results import LastChange

log = logging.getLogger(__name__)


class StateFeed(Protocol):
    """What a transport implements to feed a monitor.

    ``start(book)`` begins delivering the transport's state into ``book`` (see the module
    doc), from any thread, until ``close()``; a feed that can tell when the system's initial
    state is in calls ``book.mark_synced()`` once. ``close()`` stops it and releases what it
    holds; it is called once, after the book is closed.
    """

    def start(self, book: StateBook) -> None: ...

    def close(self) -> None: ...


class BookUpdate:
    """One change of a :class:`StateBook`, made under its lock (see the module doc)."""

    def __init__(self, states: dict[str, NodeState]) -> None:
        self._states = states
        self.events: list[MonitorEvent] = []  # queued, delivered in this order once the update ends

    def get(self, node: str) -> NodeState | None:
        return self._states.get(node)

    def node(self, node: str) -> NodeState:
        """``node``'s state, made (empty, offline) if the book holds none yet."""
        state = self._states.get(node)
        if state is None:
            state = self._states[node] = NodeState(node)
        return state

    def emit(self, event: MonitorEvent) -> None:
        self.events.append(event)

    @staticmethod
    def shown(state: NodeState, revision: int) -> int:
        """The revision an event shows: never lower than one shown before in this incarnation."""
        state.shown = max(state.shown, revision)
        return state.shown

    def set_online(self, state: NodeState, online: bool) -> None:
        """Apply a change of presence; an ``online`` or ``offline`` event if it is one."""
        if state.online == online:
            return
        state.online = online
        if not online:
            state.writer, state.duplicates = 0, []
        self.emit(
            MonitorEvent(
                EventKind.ONLINE if online else EventKind.OFFLINE,
                state.node,
                revision=self.shown(state, state.revision),
                stamp=time.time(),
                incarnation=state.incarnation,
                origin=state.origin,
                status=state.status,
            )
        )

    def set_status(self, state: NodeState, status: str | None) -> None:
        """Set ``state``'s status: a ``status`` event when it changed on a node that stays online."""
        changed, state.status = status != state.status, status
        if not (changed and state.online):
            return
        self.emit(
            MonitorEvent(
                EventKind.STATUS,
                state.node,
                revision=self.shown(state, state.revision),
                stamp=time.time(),
                incarnation=state.incarnation,
                origin=state.origin,
                status=status,
            )
        )


class StateBook:
    """Every node's state as the feed delivered it, the waits on it and the events
    (``nodes``: node ids and globs to keep, default all; ``on_event``: a first callback)."""

    def __init__(
        self, *, nodes: NodeFilter | Iterable[str] | None = None, on_event: EventCallback | None = None
    ) -> None:
        self._states: dict[str, NodeState] = {}
        self._cond = threading.Condition()
        self._callbacks: list[EventCallback] = [on_event] if on_event else []
        self._synced = False
        self._closed = False
        self._last_event = time.monotonic()  # when events were last delivered
        only = (nodes if isinstance(nodes, NodeFilter) else NodeFilter(nodes)) if nodes else None
        self._only: NodeFilter | None = only  # node ids and globs (``fleet/*``); None: every node

    def add_callback(self, fn: EventCallback) -> None:
        self._callbacks.append(fn)

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def last_event(self) -> float:
        """When (``time.monotonic()``) events were last delivered; the book's start before any."""
        return self._last_event

    # -- queries ----------------------------------------------------------------------

    def snapshot(self) -> dict[str, NodeState]:
        """A copy of every node's state as this book holds it now."""
        with self._cond:
            return {
                n: replace(
                    s,
                    parameters=dict(s.parameters),
                    blame=dict(s.blame),
                    duplicates=list(s.duplicates),
                    deleting=list(s.deleting),
                    early=list(s.early),
                )
                for n, s in self._states.items()
            }

    def last_change(self, node: str, name: str) -> LastChange | None:
        """Who last changed ``name`` on ``node``, when, through what; None when unknown."""
        with self._cond:
            state = self._states.get(canonical_node_id(node))
            return None if state is None else state.last_change(name)

    @property
    def synced(self) -> bool:
        return self._synced

    def wait_until(self, predicate: Callable[[dict[str, NodeState]], bool], timeout: float) -> bool:
        """Wait until ``predicate(states)`` holds (it sees the live dict; do not keep it)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not predicate(self._states):
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._closed:
                    return False
                self._cond.wait(remaining)
            return True

    def wait_complete(self, nodes: Iterable[str], timeout: float) -> bool:
        """Wait until the full state of every node in ``nodes`` is here."""
        wanted = [canonical_node_id(n) for n in nodes]
        pending = wanted[::-1]

        def complete(states: dict[str, NodeState]) -> bool:
            # checked on every batch of samples, with the feed's thread waiting for the lock:
            # skip the nodes already seen complete (a fleet's 10,000 scanned ~800 times took
            # seconds), then check them all once, since a node may have gained a parameter
            while pending and pending[-1] in states and states[pending[-1]].complete:
                pending.pop()
            if pending:
                return False
            pending[:] = [n for n in reversed(wanted) if not (n in states and states[n].complete)]
            return not pending

        return self.wait_until(complete, timeout)

    def wait_synced(self, timeout: float) -> bool:
        return self.wait_until(lambda _s: self._synced, timeout)

    # -- the feed's side (see the module doc) ------------------------------------------------

    def wanted(self, node: str) -> bool:
        return self._only is None or node in self._only

    @property
    def has_callbacks(self) -> bool:
        return bool(self._callbacks)

    @contextmanager
    def update(self) -> Iterator[BookUpdate]:
        """Change the book under its lock; the waiters wake up, then the events are delivered."""
        change = BookUpdate(self._states)
        with self._cond:
            yield change
            self._cond.notify_all()
        self._deliver(change.events)

    def mark_synced(self) -> None:
        with self._cond:
            self._synced = True
            self._cond.notify_all()
        self._deliver([MonitorEvent(EventKind.SYNCED, stamp=time.time())])

    def _deliver(self, events: list[MonitorEvent]) -> None:
        if events:
            self._last_event = time.monotonic()
        for event in events:
            for fn in self._callbacks:
                try:  # one failing callback must not cost the others (or the rest of the batch)
                    fn(event)
                except Exception:
                    log.exception("monitor callback %r failed on %s", fn, event.event.value)
