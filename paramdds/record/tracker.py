"""What the recorder knows of each node: its state as recorded, and the messages each monitor event makes.

A :class:`Tracker` starts from a monitor's snapshot (:meth:`Tracker.start`) and turns each
:class:`~paramdds.core.monitor_events.MonitorEvent` into the recording's messages
(:mod:`paramdds.formats.recording`), each once:

* a change the state already holds (the same value, at the same revision: the events of
  the initial sync, a sample re-sent after a stall) makes nothing;
* a change whose revision is more than one past the node's highest recorded revision
  means the monitor skipped revisions (a reader that fell behind keeps only each
  parameter's newest sample): those are read from the node's history (``fill``) and
  recorded first, marked ``source: history``; what history does not hold becomes a gap
  message with the revision range, so nothing is missed silently;
* presence (online, offline, restarted) makes a presence message when it changes what
  the tracker holds; a restart starts the node's revisions again.

Pure and not thread-safe: the recorder feeds it from one thread; ``fill`` is the one call
out (a history read).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from ..core.descriptors import ParameterDescriptor
from ..core.history import HistoryRecord
from ..core.monitor_events import EventKind, MonitorEvent, NodeState
from ..core.results import LastChange
from ..core.values import ParameterType, ParameterValue
from ..formats import recording as fmt
from ..formats.recording import Channel

Out = tuple[Channel, dict[str, object], int]  # a message: its channel, its body, its log time (ns)
# reads a node's applied changes with revisions after ``after`` and before ``before``: the
# records it holds, and a reason when it holds none (no history, the node did not answer)
Fill = Callable[[str, int, int], tuple[Sequence[HistoryRecord], str]]

_CHANGES = (EventKind.ADDED, EventKind.MODIFIED, EventKind.DELETED)
_PRESENCE = {EventKind.ONLINE: True, EventKind.OFFLINE: False}


@dataclass
class _Param:
    value: ParameterValue
    descriptor: ParameterDescriptor
    last: LastChange | None


@dataclass
class _Node:
    online: bool = False
    incarnation: int = 0
    top: int | None = None  # the highest revision recorded (None: none yet, a node seen late)
    params: dict[str, _Param] = field(default_factory=dict)


class Tracker:
    """Each node's recorded state; :meth:`on_event` makes the messages an event means."""

    def __init__(self, fill: Fill) -> None:
        self._fill = fill
        self._nodes: dict[str, _Node] = {}
        self.changes = 0  # change messages made (live and from history)
        self.gaps = 0

    def start(self, states: Mapping[str, NodeState], now_ns: int) -> list[Out]:
        """Take a monitor's snapshot as the recorded state: one snapshot message per node."""
        for name, st in sorted(states.items()):
            params = {
                k: _Param(v, d, st.last_change(k))
                for k, (v, d) in st.parameters.items()
                if v.type is not ParameterType.NOT_SET
            }
            revisions = [p.last.revision for p in params.values() if p.last is not None]
            self._nodes[name] = _Node(st.online, st.incarnation, max([st.revision, *revisions]), params)
        return self.snapshots(now_ns)

    def snapshots(self, now_ns: int) -> list[Out]:
        """A snapshot message of every node as recorded so far (each file starts with them)."""
        out: list[Out] = []
        for name, n in sorted(self._nodes.items()):
            body = fmt.snapshot_message(
                name,
                online=n.online,
                incarnation=n.incarnation,
                revision=n.top or 0,
                time_ns=now_ns,
                parameters=((k, p.value, p.descriptor, p.last) for k, p in sorted(n.params.items())),
            )
            out.append((fmt.SNAPSHOT, body, now_ns))
        return out

    @property
    def nodes(self) -> int:
        return len(self._nodes)

    def on_event(self, e: MonitorEvent, now_ns: int) -> list[Out]:
        """The messages ``e`` makes (none when the recorded state has it already)."""
        if not e.node:
            return []  # a whole site's event: its nodes' own events follow
        n = self._nodes.setdefault(e.node, _Node(incarnation=e.incarnation))
        if e.event in _CHANGES:
            return self._change(e, n, now_ns)
        if e.event in _PRESENCE:
            online = _PRESENCE[e.event]
            if n.online == online:
                return []
            n.online = online
            return [self._presence(e, online, now_ns)]
        if e.event is EventKind.RESTARTED:
            n.incarnation, n.top = e.incarnation, e.revision
            return [self._presence(e, n.online, now_ns)]
        return []

    def _presence(self, e: MonitorEvent, online: bool, now_ns: int) -> Out:
        t = _stamp_ns(e.stamp, now_ns)
        body = fmt.presence_message(
            e.node, e.event.value, online=online, incarnation=e.incarnation, revision=e.revision, time_ns=t
        )
        return (fmt.PRESENCE, body, t)

    def _change(self, e: MonitorEvent, n: _Node, now_ns: int) -> list[Out]:
        held = n.params.get(e.name)
        last = e.last_change
        revision = last.revision if last is not None else e.revision
        deleted = e.event is EventKind.DELETED or e.value is None or e.value.type is ParameterType.NOT_SET
        if deleted and held is None:
            return []  # not held: nothing to delete
        if not deleted and held is not None and _same(held, e.value, e.descriptor, last):
            return []  # the recorded state has it (the initial sync, a re-sent sample)
        out: list[Out] = []
        if n.top is not None and revision > n.top + 1:
            out.extend(self._filled(e.node, n, n.top, revision, now_ns))
            held = n.params.get(e.name)
        t = last.time_ns if last is not None else _stamp_ns(e.stamp, now_ns)
        new = None if deleted else e.value
        old = held.value if held is not None else None
        who, verified, via = (last.who, last.verified, last.via) if last is not None else ("", False, "")
        body = fmt.change_message(
            e.node, e.name, old, new, who=who, verified=verified, via=via, revision=revision, time_ns=t
        )
        out.append((fmt.CHANGES, body, t))
        self.changes += 1
        if new is None:
            n.params.pop(e.name, None)
        else:
            n.params[e.name] = _Param(new, e.descriptor or _descriptor(e.name, held, new), last)
        n.top = revision if n.top is None else max(n.top, revision)
        return out

    def _filled(self, node: str, n: _Node, after: int, before: int, now_ns: int) -> list[Out]:
        """Revisions after ``after`` and before ``before`` from the node's history; a gap
        message for each run of them it does not hold."""
        records, reason = self._fill(node, after, before)
        out: list[Out] = []
        have = sorted((r for r in records if after < r.revision < before), key=lambda r: (r.revision, r.seq))
        last = after
        for r in have:
            if r.revision > last + 1:
                out.append(self._gap(node, last, r.revision, reason or "not in the node's history", now_ns))
            held = n.params.get(r.name)
            body = fmt.change_message(
                node, r.name, r.old, r.new, who=r.who, verified=r.verified, via=r.via,
                revision=r.revision, time_ns=r.time_ns, source="history",
            )  # fmt: skip
            out.append((fmt.CHANGES, body, r.time_ns))
            self.changes += 1
            if r.new is None:
                n.params.pop(r.name, None)
            else:
                lc = LastChange(r.who, r.verified, r.via, r.time_ns, r.revision)
                n.params[r.name] = _Param(r.new, _descriptor(r.name, held, r.new), lc)
            last = r.revision
        if before > last + 1:
            out.append(self._gap(node, last, before, reason or "not in the node's history", now_ns))
        return out

    def _gap(self, node: str, after: int, before: int, reason: str, now_ns: int) -> Out:
        self.gaps += 1
        return (fmt.GAPS, fmt.gap_message(node, after, before, reason, now_ns), now_ns)


def _same(
    held: _Param,
    value: ParameterValue | None,
    descriptor: ParameterDescriptor | None,
    last: LastChange | None,
) -> bool:
    """Whether an event says what is held: the same value, and the same change (revision
    and author) when the writer keeps blame."""
    if value is None or not held.value.same_as(value):
        return False
    if descriptor is not None and descriptor != held.descriptor:
        return False
    if last is None or held.last is None:
        return last is None and held.last is None
    return last.revision == held.last.revision and last.who == held.last.who


def _descriptor(name: str, held: _Param | None, value: ParameterValue) -> ParameterDescriptor:
    """The descriptor held, while the type stays; else the type's plain one."""
    if held is not None and held.descriptor.type is value.type:
        return held.descriptor
    return ParameterDescriptor(name, value.type)


def _stamp_ns(stamp: float, now_ns: int) -> int:
    return round(stamp * 1e9) if stamp > 0 else now_ns
