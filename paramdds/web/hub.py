"""Monitor events → coalesced server-sent events, per subscriber, for what it shows.

The monitor calls :meth:`Hub.on_event` on Cyclone's receive thread: it only
appends the event to a list and, for the first event of a burst, asks the event
loop to flush :data:`FLUSH_DELAY` seconds later. A flush turns the whole burst
into at most three messages per subscriber:

``params``  the rows of the subscriber's selected node that changed (last value
            wins), the names deleted, and the node's summary;
``nodes``   summaries of the nodes that changed (so a visible row updates its
            revision, count or online state), or ``{"refresh": true}`` when more
            than :data:`MAX_NODE_UPDATES` changed (the page then re-reads its page);
``log``     the newest :data:`LOG_LIMIT` events of the burst and how many were left out
            (a whole site going offline or coming back is its one event, not one per node).

A subscriber whose queue is full (a stalled browser) gets no more messages until
it drains, then one ``resync``: the page reloads its view instead of replaying.

Over Zenoh (:meth:`Hub.follow_sites`) the sites the view lacks are compared with those
last told at every flush and every :data:`SITES_CHECK` seconds (a site's answer or refusal
ends a query, not always with an event); when they differ, every subscriber gets
``nodes`` ``{"refresh": true}`` and the page re-reads its page, which lists them.
"""

from __future__ import annotations

import asyncio
import json
import time
from dataclasses import dataclass, field

from ..dds.monitor import EventKind, MonitorEvent
from ..listen import Handover
from .model import Row, parameter_row, summary_json
from .view import Lacking, StateView

FLUSH_DELAY = 0.015  # seconds a burst may gather before it is sent
MAX_NODE_UPDATES = 200
LOG_LIMIT = 50
QUEUE_SIZE = 256  # messages per subscriber
SITES_CHECK = 1.0  # seconds between looks at the sites lacking (over Zenoh)


def sse(event: str, data: object) -> str:
    return f"event: {event}\ndata: {json.dumps(data, allow_nan=False, separators=(',', ':'))}\n\n"


@dataclass(eq=False)
class Subscriber:
    node: str  # the node whose rows it shows ("" for none)
    queue: asyncio.Queue[str | None] = field(default_factory=lambda: asyncio.Queue(QUEUE_SIZE))
    stalled: bool = False

    def put(self, message: str) -> None:
        if self.stalled and self.queue.qsize() < QUEUE_SIZE // 2:
            self.stalled = False
            self.queue.put_nowait(sse("resync", {}))
        if self.stalled:
            return
        try:
            self.queue.put_nowait(message)
        except asyncio.QueueFull:
            self.stalled = True


def log_entry(e: MonitorEvent) -> Row:
    last = e.last_change
    return {
        "event": e.event.value,
        "node": e.node,
        "site": e.site,  # a site_offline / site_online / site_status event's site ("" for the others)
        "origin": e.origin,  # "ros2": shown with its leading slash
        "status": e.status,  # a (site_)status event's new status ("unreachable", "stale"; None: normal)
        "name": e.name,
        "revision": e.revision,
        "value": parameter_row(e.name, e.value, e.descriptor)["value"] if e.value is not None else None,
        "type": e.value.type.label if e.value is not None else None,  # shown as the node shows it (2.0)
        "stamp": e.stamp or time.time(),
        "who": last.who if last is not None else None,  # who made this change, if the node said
    }


class Hub:
    def __init__(self, view: StateView, loop: asyncio.AbstractEventLoop) -> None:
        self._view = view
        self._loop = loop
        self._events = Handover(loop, self._flush, FLUSH_DELAY)
        self._subscribers: set[Subscriber] = set()
        self._closed = False
        self._lacking: list[Lacking] | None = None  # the sites lacking last told (None: not followed)

    # -- the monitor's side (Cyclone's thread) ----------------------------------------------

    def on_event(self, event: MonitorEvent) -> None:
        if event.node and event.event is not EventKind.DELETED:
            self._view.note_revision(event.node, event.revision, event.incarnation)
        self._events.put(event)

    # -- the event loop's side ----------------------------------------------------------------

    def follow_sites(self) -> None:
        """Tell the pages when the sites the view lacks change (over Zenoh; see the module doc)."""
        self._lacking = self._view.lacking()
        self._loop.call_later(SITES_CHECK, self._check_sites)

    def _check_sites(self) -> None:
        if self._closed:
            return
        if self._sites_changed():
            for sub in list(self._subscribers):
                sub.put(sse("nodes", {"refresh": True}))
        self._loop.call_later(SITES_CHECK, self._check_sites)

    def _sites_changed(self) -> bool:
        """Whether the sites lacking differ from those last told (remembered as told)."""
        if self._lacking is None:
            return False
        lacking = self._view.lacking()
        if lacking == self._lacking:
            return False
        self._lacking = lacking
        return True

    def subscribe(self, node: str) -> Subscriber:
        sub = Subscriber(node)
        self._subscribers.add(sub)
        return sub

    def unsubscribe(self, sub: Subscriber) -> None:
        self._subscribers.discard(sub)

    def close(self) -> None:
        """End every stream (each gets ``None``)."""
        self._closed = True
        self._events.close()
        for sub in list(self._subscribers):
            try:
                sub.queue.put_nowait(None)
            except asyncio.QueueFull:
                sub.queue.get_nowait()
                sub.queue.put_nowait(None)
        self._subscribers.clear()

    def _flush(self, events: list[MonitorEvent]) -> None:
        if not self._subscribers:
            return
        changed = list(dict.fromkeys(e.node for e in events if e.node))
        refresh = self._sites_changed()  # a site lacking came, or one went: the page re-reads its page
        if refresh or len(changed) > MAX_NODE_UPDATES:
            nodes_message = sse("nodes", {"refresh": True})
        else:
            nodes_message = sse("nodes", {"nodes": [summary_json(s) for s in self._view.summaries(changed)]})
        # a node that went or came with its whole site is the site's one line, not its own
        told = [e for e in events if not e.by_site]
        shown = [e for e in told if e.event is not EventKind.SYNCED][-LOG_LIMIT:]
        log_message = sse("log", {"events": [log_entry(e) for e in shown], "skipped": len(told) - len(shown)})
        by_node = {sub.node for sub in self._subscribers if sub.node}
        params = {node: self._params_message(node, events) for node in by_node if node in changed}
        for sub in list(self._subscribers):
            if sub.node in params:
                sub.put(params[sub.node])
            if changed or refresh:
                sub.put(nodes_message)
            sub.put(log_message)

    def _params_message(self, node: str, events: list[MonitorEvent]) -> str:
        rows: dict[str, Row] = {}
        deleted: dict[str, None] = {}
        for e in events:
            if e.node != node or not e.name:
                continue
            if e.event is EventKind.DELETED:
                rows.pop(e.name, None)
                deleted[e.name] = None
            elif e.value is not None:
                rows[e.name] = parameter_row(e.name, e.value, e.descriptor, e.last_change)
                deleted.pop(e.name, None)
        summaries = self._view.summaries([node])
        return sse(
            "params",
            {
                "node": node,
                "summary": summary_json(summaries[0]) if summaries else None,
                "rows": list(rows.values()),
                "deleted": list(deleted),
            },
        )
