"""What ``paramdds watch`` prints: monitor events as JSON lines or one readable line each."""

from __future__ import annotations

import sys
import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..core.jsonform import json_value
from ..core.names import shown_node
from ._output import dumps_json, typed

if TYPE_CHECKING:
    from ..core.history import HistoryRecord
    from ..core.replay import Gap
    from ..dds.monitor import MonitorEvent


def matches_prefix(name: str, prefixes: Sequence[str]) -> bool:
    """ROS list semantics: ``robot`` matches ``robot`` and ``robot.x``, not ``robotic``."""
    if not prefixes:
        return True
    for p in prefixes:
        p = p.rstrip(".")
        if not p or name == p or name.startswith(p + "."):
            return True
    return False


class EventPrinter:
    """Prints monitor events as ``watch`` does: JSON lines or one readable line each.

    Called on the monitor's threads; one lock keeps lines whole. Node presence events
    are printed only after ``synced`` (before it, the ``added`` events are the state); a
    whole site going offline or coming back (over Zenoh) is one line, the site's, not one
    per node. With ``changes=False`` the monitor's parameter events are not printed: a
    watch from a revision prints the node's history records instead (:meth:`record`),
    with who made each change.
    """

    def __init__(self, output: str, prefixes: Sequence[str], *, changes: bool = True) -> None:
        self._json = output == "json"
        self._prefixes = list(prefixes)
        self._changes = changes
        self._lock = threading.Lock()
        self._synced = False
        self.broken = threading.Event()

    def __call__(self, event: MonitorEvent) -> None:
        from ..dds.monitor import EventKind

        if event.event is EventKind.SYNCED:
            return  # printed by :meth:`synced`, once the state has settled (ParameterMonitor.settle)
        if event.event in (EventKind.SITE_OFFLINE, EventKind.SITE_ONLINE, EventKind.SITE_STATUS):
            if self._synced:
                self._write(self._site_line(event))
            return
        if event.event in (EventKind.ONLINE, EventKind.OFFLINE, EventKind.RESTARTED, EventKind.STATUS):
            if self._synced and not event.by_site:  # one line for a whole site: the site's
                self._write(self._node_line(event))
            return
        if self._changes and matches_prefix(event.name, self._prefixes):
            self._write(self._parameter_line(event))

    def record(self, r: HistoryRecord) -> None:
        """A change read from the node's history, as a parameter event with who made it:
        ``modified NODE NAME = VALUE  (rev N)  by WHO via VIA``."""
        if not matches_prefix(r.name, self._prefixes):
            return
        kind = "added" if r.old is None else "deleted" if r.new is None else "modified"
        if self._json:
            line = {
                "event": kind,
                "node": r.node,
                "name": r.name,
                "type": r.new.type.label if r.new is not None else "not_set",
                "value": json_value(r.new),
                "revision": r.revision,
                "stamp": r.time_ns / 1e9,
                "who": r.who,
                "verified": r.verified,
                "via": r.via,
            }
            self._write(dumps_json(line, pretty=False))
            return
        shown = "" if r.new is None else f" = {typed(r.new)}"
        who = r.who if r.verified else f"{r.who} (claimed)"
        self._write(f"{kind:<8} {r.node} {r.name}{shown}  (rev {r.revision})  by {who} via {r.via}")

    def gap(self, node: str, gap: Gap) -> None:
        """Revisions of ``node`` that neither history nor the live stream holds: one line."""
        one = gap.before == gap.after + 2
        lost = f"revision {gap.after + 1}" if one else f"revisions {gap.after + 1}-{gap.before - 1}"
        if self._json:
            line = {"event": "gap", "node": node, "after": gap.after, "before": gap.before}
            self._write(dumps_json(line, pretty=False))
        else:
            self._write(f"gap      {node} {lost} lost: not in the node's history")

    def synced(self, settled: bool = True, waited: float = 0.0) -> None:
        """Print the ``synced`` line: the current state has been printed. When discovery
        did not settle within the timeout, say so (``not_synced``) instead."""
        with self._lock:
            self._synced = True
        if settled:
            self._write('{"event": "synced"}' if self._json else "synced")
        elif self._json:
            self._write(dumps_json({"event": "not_synced", "waited": round(waited, 3)}, pretty=False))
        else:
            self._write(f"not synced: the state did not settle within {waited:g} s; it may be incomplete")

    def _site_line(self, e: MonitorEvent) -> str:
        """A whole site went offline (every gateway of it) or came back, or its nodes went stale
        (``site_status SITE stale``: held while its gateways are gone) or fresh again
        (``site_status SITE ok``): one line."""
        from ..dds.monitor import EventKind

        status = e.event is EventKind.SITE_STATUS
        if self._json:
            line: dict[str, object] = {"event": e.event.value, "site": e.site, "stamp": e.stamp}
            return dumps_json({**line, "status": e.status} if status else line, pretty=False)
        return f"{e.event.value} {e.site} {e.status or 'ok'}" if status else f"{e.event.value} {e.site}"

    def _node_line(self, e: MonitorEvent) -> str:
        from ..dds.monitor import EventKind

        status = e.event is EventKind.STATUS  # the node's new status: "unreachable", "stale", None
        if self._json:
            line: dict[str, object] = {
                "event": e.event.value,
                "node": shown_node(e.node, e.origin),
                "name": None,
                "type": None,
                "value": None,
                "revision": e.revision,
                "stamp": e.stamp,
            }
            return dumps_json({**line, "status": e.status} if status else line, pretty=False)
        text = f"{e.event.value:<8} {shown_node(e.node, e.origin)}"
        return f"{text} {e.status or 'ok'}" if status else text

    def _parameter_line(self, e: MonitorEvent) -> str:
        from ..dds.monitor import EventKind

        value = None if e.event is EventKind.DELETED else e.value
        if self._json:
            return dumps_json(
                {
                    "event": e.event.value,
                    "node": shown_node(e.node, e.origin),
                    "name": e.name,
                    "type": value.type.label if value is not None else "not_set",
                    "value": json_value(value),
                    "revision": e.revision,
                    "stamp": e.stamp,
                },
                pretty=False,
            )
        shown = "" if value is None else f" = {typed(value)}"
        return f"{e.event.value:<8} {shown_node(e.node, e.origin)} {e.name}{shown}  (rev {e.revision})"

    def _write(self, line: str) -> None:
        with self._lock:
            try:
                sys.stdout.write(line + "\n")
                sys.stdout.flush()
            except OSError:
                self.broken.set()
