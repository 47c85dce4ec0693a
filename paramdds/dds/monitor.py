"""The monitor: one reader on ``ParameterEvents`` watches every node in the system.

Because ``ParameterEvents`` is keyed by (node_id, name) and TRANSIENT_LOCAL, a
monitor that starts late receives each node's whole current table, not the last
change (trap 1 of docs/wire.md). From the instance states it derives:

* a parameter sample whose name is new to the node → ``added``, else ``modified``;
* a parameter instance disposed → ``deleted``;
* the presence instance (name ``""``) alive → ``online``; no writers (graceful
  stop, or a killed server after its 1 s liveliness lease) → ``offline``. An
  offline node keeps its last values.

Events report changes, so a watcher sees the same story whatever it missed:

* after a stall, an offline/online or a restart the node's table arrives again; a
  sample whose value and descriptor equal what the monitor holds is no event;
* a sample of a new incarnation (the node's server started again) is one
  ``restarted`` event, then only what differs from before; a node online until then
  and hosted again by the same process (a bridge's mirror of a restarted ROS 2 node)
  goes ``offline`` first (its old incarnation is gone, even when its going came too
  fast to be seen), so such a restart always shows offline, restarted, online;
* within one incarnation an event never carries a revision lower than one emitted
  before for that node (a re-delivered sample keeps the revision it was written at;
  it is reported at the highest revision shown, the state it is part of);
* the events of a node whose presence has not arrived yet (a late joiner receives the
  instances in any order) wait for it, so each event carries the node's origin;
* a deletion carries no revision of its own: ``deleted`` is emitted with the revision
  of the node's presence sample that follows it (the server writes one after every
  change set), the revision of the delete's reply.

``synced`` is emitted once, when every node seen holds as many parameters as its
presence announces and no sample has arrived for :data:`QUIET` seconds.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from functools import partial
from typing import Any

from cyclonedds.core import InstanceState, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Qos
from cyclonedds.topic import Topic

from ..core.descriptors import ParameterDescriptor
from ..core.names import NodeFilter, canonical_node_id
from ..core.values import ParameterValue
from .dispatch import Dispatcher
from .filters import gone_of, origin_of, process_label, request_filter_of, status_of
from .participant import poll_peers
from .qos import QosProfiles
from .transport import transport_of
from .wire import types as wire
from .wire.state import StateKey, StateSample, decode_key, decode_state

log = logging.getLogger(__name__)

QUIET = 0.1  # seconds without new samples before the initial state counts as received


class EventKind(str, Enum):
    ADDED = "added"
    MODIFIED = "modified"
    DELETED = "deleted"
    ONLINE = "online"
    OFFLINE = "offline"
    RESTARTED = "restarted"  # the node's server started again (a new incarnation)
    STATUS = "status"  # an online node's status changed (NodeState.status; None: back to normal)
    SYNCED = "synced"


@dataclass(frozen=True)
class MonitorEvent:
    """A change a monitor saw: a parameter's new state, or a node going on or offline."""

    event: EventKind
    node: str = ""
    name: str = ""
    value: ParameterValue | None = None
    descriptor: ParameterDescriptor | None = None
    revision: int = 0
    stamp: float = 0.0  # seconds since the epoch, from the writer
    incarnation: int = 0  # the server's for the node (new on every start): see NodeState.incarnation
    origin: str | None = None  # the node's presence tag "origin" ("ros2": mirrored by the bridge), if known
    status: str | None = None  # the node's status (see NodeState.status) on online and status events


@dataclass
class NodeState:
    """What a monitor holds of one node: its presence and its parameters."""

    node: str
    online: bool = False
    host: str = ""
    pid: int = 0
    revision: int = 0
    announced: int = -1  # parameter count from the presence instance; -1 before it is seen
    # other processes seen publishing this node's presence while it was online ("pid N on H"):
    # one node id hosted twice, whose requests reach both
    duplicates: list[str] = field(default_factory=list)
    writer: int = 0  # the publication handle of the last presence sample
    request_filter: str | None = None  # "native" or "handler" as the server says; None if it does not
    # the server's for this node, new on every start: a different one is a restart, whose
    # revisions start again (compare-and-set compares both; see ParameterClient.set)
    incarnation: int = 0
    origin: str | None = None  # the presence tag "origin" ("ros2": mirrored by the bridge); None if unsaid
    # the presence tag "status": "unreachable" for a ROS 2 node the bridge sees but cannot read
    # (no parameters; requests fail with UNAVAILABLE); None for a node that is what it says
    status: str | None = None
    parameters: dict[str, tuple[ParameterValue, ParameterDescriptor]] = field(default_factory=dict)
    shown: int = 0  # the highest revision an event showed for this incarnation
    # deletions waiting for the presence sample that gives their revision (see the module doc)
    deleting: list[tuple[str, ParameterValue, ParameterDescriptor]] = field(default_factory=list)
    # events of a node whose presence has not arrived yet: emitted with it, once its origin is known
    early: list[MonitorEvent] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when this monitor holds every parameter the node announced."""
        return self.announced == len(self.parameters)


EventCallback = Callable[[MonitorEvent], None]


class MonitorBase:
    """What every monitor holds and offers, whatever feeds it: each node's state, the
    queries and waits on it (:meth:`snapshot`, :meth:`wait_until`, :meth:`wait_complete`,
    :meth:`wait_synced`) and the events.

    :class:`ParameterMonitor` feeds it from DDS. A monitor on another transport (the
    remote monitor of :mod:`paramdds.zenoh.remote`) subclasses ParameterMonitor, so that
    it is one wherever a monitor is taken, calls ``MonitorBase.__init__`` instead of the
    DDS one, and feeds the state through this protected interface, kept for them:

    * ``_cond``: the condition that guards ``_states`` (node -> :class:`NodeState`): change
      states while holding it, then ``notify_all``; ``_closed`` is True once closed;
    * ``_only``: the ``nodes`` filter (a :class:`~paramdds.core.names.NodeFilter`) or None,
      and ``_wanted(node)``: whether this monitor keeps ``node`` (a subclass may narrow it);
    * ``_has_callbacks``: whether events are worth making (none is delivered otherwise);
    * ``_touch()``: a sample arrived now (under ``_cond``);
    * ``_set_online(state, online)``: apply a change of presence; its event, or None;
    * ``_status_event(state, status)``: apply a node's status; its event, or None;
    * ``_emit(events)``: deliver events to the callbacks (outside ``_cond``);
    * ``_mark_synced()``: the initial state is here (``synced``, once; waits wake up).
    """

    def __init__(
        self, *, nodes: NodeFilter | Iterable[str] | None = None, on_event: EventCallback | None = None
    ) -> None:
        self._states: dict[str, NodeState] = {}
        self._cond = threading.Condition()
        self._callbacks: list[EventCallback] = [on_event] if on_event else []
        self._last_sample = time.monotonic()
        self._synced = False
        self._closed = False
        only = (nodes if isinstance(nodes, NodeFilter) else NodeFilter(nodes)) if nodes else None
        self._only: NodeFilter | None = only  # node ids and globs (``fleet/*``); None: every node

    def add_callback(self, fn: EventCallback) -> None:
        self._callbacks.append(fn)

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def __enter__(self) -> MonitorBase:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- queries ----------------------------------------------------------------------

    def snapshot(self) -> dict[str, NodeState]:
        """A copy of every node's state as this monitor holds it now."""
        with self._cond:
            return {
                n: replace(
                    s,
                    parameters=dict(s.parameters),
                    duplicates=list(s.duplicates),
                    deleting=list(s.deleting),
                    early=list(s.early),
                )
                for n, s in self._states.items()
            }

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
            # checked on every batch of samples, with the dispatch thread waiting for the lock:
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

    # -- the protected interface of the feeders (see the class doc) ------------------------

    def _wanted(self, node: str) -> bool:
        return self._only is None or node in self._only

    @property
    def _has_callbacks(self) -> bool:
        return bool(self._callbacks)

    def _touch(self) -> None:
        self._last_sample = time.monotonic()

    def _mark_synced(self) -> None:
        with self._cond:
            self._synced = True
            self._cond.notify_all()
        self._emit([MonitorEvent(EventKind.SYNCED, stamp=time.time())])

    @staticmethod
    def _shown(state: NodeState, revision: int) -> int:
        """The revision an event shows: never lower than one shown before in this incarnation."""
        state.shown = max(state.shown, revision)
        return state.shown

    def _set_online(self, state: NodeState, online: bool) -> MonitorEvent | None:
        if state.online == online:
            return None
        state.online = online
        if not online:
            state.writer, state.duplicates = 0, []
        kind = EventKind.ONLINE if online else EventKind.OFFLINE
        return MonitorEvent(
            kind,
            state.node,
            revision=self._shown(state, state.revision),
            stamp=time.time(),
            incarnation=state.incarnation,
            origin=state.origin,
            status=state.status,
        )

    def _status_event(self, state: NodeState, status: str | None) -> MonitorEvent | None:
        """Set ``state``'s status: a STATUS event when it changed on a node that stays online
        (going online or offline is an event of its own, which carries the status)."""
        changed, state.status = status != state.status, status
        if not (changed and state.online):
            return None
        return MonitorEvent(
            EventKind.STATUS,
            state.node,
            revision=self._shown(state, state.revision),
            stamp=time.time(),
            incarnation=state.incarnation,
            origin=state.origin,
            status=status,
        )

    def _emit(self, events: list[MonitorEvent]) -> None:
        for event in events:
            for fn in self._callbacks:
                try:  # one failing callback must not cost the others (or the rest of the batch)
                    fn(event)
                except Exception:
                    log.exception("monitor callback %r failed on %s", fn, event.event.value)


class ParameterMonitor(MonitorBase):
    """Every node's state and events, from one DDS reader of ``ParameterEvents`` (``nodes``:
    ids and globs to keep; default all)."""

    def __init__(
        self,
        participant: DomainParticipant,
        qos: QosProfiles | None = None,
        *,
        nodes: Iterable[str] | None = None,
        on_event: EventCallback | None = None,
    ) -> None:
        super().__init__(nodes=nodes, on_event=on_event)
        qos = qos or QosProfiles.load()
        # no topic filter (it deadlocks against take under load): _apply skips other nodes
        topic = Topic(participant, "ParameterEvents", wire.ParameterEvent)
        # its tick looks into peers whose type or QoS does not match (see .peers)
        self._dispatcher = Dispatcher(
            participant, "paramdds-monitor", tick=partial(poll_peers, participant), period=1.0
        )
        # depth 4, not 1: a late joiner must see the presence samples of every writer of one
        # node (two processes hosting one node id), not only the last one delivered
        reader_qos = qos.reader("ParameterEvents") + Qos(Policy.History.KeepLast(4))
        transport = transport_of(participant)  # secure: the identity's node partitions, checked per sample
        reader = transport.reader(topic, reader_qos)
        self._dispatcher.add_raw(reader, _decode, transport.guard_raw(reader, self._on_samples))
        self._dispatcher.start()
        self._sync_thread = threading.Thread(target=self._watch_sync, name="paramdds-sync", daemon=True)
        self._sync_thread.start()

    def close(self) -> None:
        super().close()
        self._dispatcher.close()

    def __enter__(self) -> ParameterMonitor:
        return self

    # -- samples → state and events -------------------------------------------------------

    def _on_samples(self, samples: Sequence[tuple[StateSample | StateKey, Any]]) -> None:
        events: list[MonitorEvent] = []
        with self._cond:
            self._last_sample = time.monotonic()
            for s, info in samples:
                self._apply(s, info, events)
            self._cond.notify_all()
        self._emit(events)

    def _apply(self, s: StateSample | StateKey, info: Any, events: list[MonitorEvent]) -> None:
        if self._only is not None and s.node_id not in self._only:
            return
        state = self._states.get(s.node_id)
        if state is None:
            state = self._states[s.node_id] = NodeState(s.node_id)
        if not isinstance(s, StateSample):  # no data: the instance was disposed or lost its writers
            if s.name == "":
                self._flush_deleted(state, state.revision, events)
                self._add(events, self._set_online(state, False))
            elif info.instance_state == InstanceState.NotAliveDisposed and s.name in state.parameters:
                value, descriptor = state.parameters.pop(s.name)
                if self._callbacks:  # emitted with the revision of the presence that follows
                    state.deleting.append((s.name, value, descriptor))
            return  # "no writers" on a parameter: the node is offline, keep its value
        self._check_incarnation(state, s, info, events)
        if s.kind == wire.EVENT_PRESENCE and s.name == "":
            self._flush_deleted(state, s.revision, events)
            events += self._apply_presence(state, s, info)
            events += [replace(e, origin=state.origin) for e in state.early]
            state.early.clear()
            return
        held = state.parameters.get(s.name)
        state.parameters[s.name] = (s.value, s.descriptor)
        if not self._callbacks:
            return  # an event exists only to be emitted: a monitor's full state is 5,000+ samples
        if held is not None and held[0].same_as(s.value) and held[1] == s.descriptor:
            return  # the same again (re-sent after a stall or a restart): no change to report
        self._flush_deleted(state, s.revision, events)
        kind = EventKind.MODIFIED if held is not None else EventKind.ADDED
        (events if state.announced >= 0 else state.early).append(
            MonitorEvent(
                kind,
                state.node,
                s.name,
                s.value,
                s.descriptor,
                self._shown(state, s.revision),
                s.stamp,
                s.incarnation,
                origin=state.origin,
            )
        )

    @staticmethod
    def _add(events: list[MonitorEvent], event: MonitorEvent | None) -> None:
        if event is not None:
            events.append(event)

    def _check_incarnation(
        self, state: NodeState, s: StateSample, info: Any, events: list[MonitorEvent]
    ) -> None:
        """A sample of another incarnation than the one held: the node's server started again."""
        if not s.incarnation or s.incarnation == state.incarnation:
            return
        # two processes hosting one node id (a warned misconfiguration, see duplicates) each have
        # an incarnation of their own: their samples alternating is no restart
        restarted = state.incarnation != 0 and not state.duplicates
        if restarted and state.online and state.writer == int(getattr(info, "publication_handle", 0)):
            # hosted again by the same writer (process): the old incarnation is gone even when its
            # going was never seen (a restart faster than this reader's look: keyed state kept
            # only the new presence), so offline first. From another writer it may be a second
            # host of the node id (see duplicates), told apart by the presence that follows.
            self._flush_deleted(state, state.revision, events)
            self._add(events, self._set_online(state, False))
        state.incarnation, state.shown = s.incarnation, 0
        if restarted and self._callbacks:
            self._flush_deleted(state, state.revision, events)
            events.append(
                MonitorEvent(
                    EventKind.RESTARTED,
                    state.node,
                    revision=s.revision,
                    stamp=time.time(),
                    incarnation=s.incarnation,
                    origin=state.origin,
                )
            )

    def _flush_deleted(self, state: NodeState, revision: int, events: list[MonitorEvent]) -> None:
        for name, value, descriptor in state.deleting:
            events.append(
                MonitorEvent(
                    EventKind.DELETED,
                    state.node,
                    name,
                    value,
                    descriptor,
                    self._shown(state, revision),
                    time.time(),
                    state.incarnation,
                    origin=state.origin,
                )
            )
        state.deleting.clear()

    def _apply_presence(self, state: NodeState, s: StateSample, info: Any) -> list[MonitorEvent]:
        writer = int(getattr(info, "publication_handle", 0))
        tags = s.value.value  # a string array of the server's tags, or NOT_SET
        if not isinstance(tags, tuple):
            tags = ()
        gone = gone_of(tags)
        if gone:  # the other host of this node stopped: it is neither shown nor a second host
            state.duplicates = [d for d in state.duplicates if d not in gone]
        if (
            state.online
            and state.writer
            and writer != state.writer
            and (s.host, s.pid) != (state.host, state.pid)
            and process_label(state.host, state.pid) not in gone
        ):
            # a second live writer of this node's presence: two processes host one node id
            previous, new = process_label(state.host, state.pid), process_label(s.host, s.pid)
            state.duplicates = [d for d in state.duplicates if d != new]  # host and pid show the new one
            if previous not in state.duplicates:
                state.duplicates.append(previous)
                log.warning(
                    "node %r is hosted by two processes: %s and %s; requests reach both",
                    state.node,
                    previous,
                    new,
                )
        state.writer = writer
        state.host, state.pid = s.host, s.pid
        state.revision, state.announced = s.revision, s.parameter_count
        state.incarnation = s.incarnation
        state.request_filter = request_filter_of(tags)
        state.origin = origin_of(tags)
        events: list[MonitorEvent] = []
        self._add(events, self._status_event(state, status_of(tags)))
        self._add(events, self._set_online(state, info.instance_state == InstanceState.Alive))
        return events

    def _watch_sync(self) -> None:
        with self._cond:
            while not self._closed:
                quiet_for = time.monotonic() - self._last_sample
                if quiet_for >= QUIET and all(s.complete or not s.online for s in self._states.values()):
                    self._synced = True
                    self._cond.notify_all()
                    break
                self._cond.wait(max(0.005, QUIET - quiet_for))
        if self._synced:
            self._emit([MonitorEvent(EventKind.SYNCED, stamp=time.time())])


def _decode(data: bytes, info: Any) -> StateSample | StateKey:
    return decode_state(data) if info.valid_data else decode_key(data)
