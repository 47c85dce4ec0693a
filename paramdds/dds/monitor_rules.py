"""The monitor's rules on DDS: what each ``ParameterEvents`` sample changes and which events it makes.

Because ``ParameterEvents`` is keyed by (node_id, name) and TRANSIENT_LOCAL, a
monitor that starts late receives each node's whole current table, not the last
change (trap 1 of docs/wire.md). From the instance states it derives:

* a parameter sample whose name is new to the node → ``added``, else ``modified``; the
  sample's blame (who, verified, via, stamp, revision) is the parameter's last change,
  held and carried by the event (unknown when the writer keeps none);
* a parameter instance disposed → ``deleted`` (also when its value arrives with the
  instance already disposed: a late joiner whose retained sample was disposed meanwhile);
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

These are pure: :func:`apply_sample` takes a decoded sample and what the reader said of its
instance (:class:`Delivery`); the reader itself is :mod:`.monitor_feed`'s.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace
from typing import Protocol

from cyclonedds.core import InstanceState

from ..core.monitor_events import Blame, EventKind, MonitorEvent, NodeState, last_change_of
from ..core.state_book import BookUpdate, StateBook
from .filters import gone_of, origin_of, process_label, request_filter_of, status_of
from .wire import types as wire
from .wire.state import StateKey, StateSample

log = logging.getLogger(__name__)


class Delivery(Protocol):
    """What the reader says of a sample's instance (a Cyclone ``SampleInfo`` has both):
    its state (an :class:`~cyclonedds.core.InstanceState` constant) and its writer."""

    @property
    def instance_state(self) -> int: ...

    @property
    def publication_handle(self) -> int: ...


def apply_sample(book: StateBook, change: BookUpdate, s: StateSample | StateKey, info: Delivery) -> None:
    """Apply one ``ParameterEvents`` sample (or a key without data) delivered with ``info``
    to ``book``, in its update ``change``: the rules of the module doc."""
    if not book.wanted(s.node_id):
        return
    state = change.node(s.node_id)
    if not isinstance(s, StateSample):  # no data: the instance was disposed or lost its writers
        if s.name == "":
            _flush_deleted(change, state, state.revision)
            change.set_online(state, False)
        elif info.instance_state == InstanceState.NotAliveDisposed:
            _delete(book, state, s.name)
        return  # "no writers" on a parameter: the node is offline, keep its value
    if s.name != "" and info.instance_state == InstanceState.NotAliveDisposed:
        # the value and its dispose both arrived before this take (a late joiner's retained
        # sample, disposed meanwhile): the reader shows the data with the instance disposed
        _delete(book, state, s.name)
        return
    _check_incarnation(book, change, state, s, info)
    if s.kind == wire.EVENT_PRESENCE and s.name == "":
        _flush_deleted(change, state, s.revision)
        _apply_presence(change, state, s, info)
        for early in state.early:
            change.emit(replace(early, origin=state.origin))
        state.early.clear()
        return
    held = state.parameters.get(s.name)
    state.parameters[s.name] = (s.value, s.descriptor)
    before = state.blame.get(s.name)
    blame: Blame | None = None
    if s.who:
        blame = state.blame[s.name] = _blame_of(state, s)
    elif state.blame:
        state.blame.pop(s.name, None)  # a writer without blame: no longer known
    if not book.has_callbacks:
        return  # an event exists only to be emitted: a monitor's full state is 5,000+ samples
    if (
        held is not None
        and held[0].same_as(s.value)
        and held[1] == s.descriptor
        and not _recommitted(before, blame)
    ):
        return  # the same again (re-sent after a stall or a restart): no change to report
    _flush_deleted(change, state, s.revision)
    event = MonitorEvent(
        EventKind.MODIFIED if held is not None else EventKind.ADDED,
        state.node,
        s.name,
        s.value,
        s.descriptor,
        change.shown(state, s.revision),
        s.stamp,
        s.incarnation,
        origin=state.origin,
        last_change=last_change_of(blame),
    )
    if state.announced >= 0:
        change.emit(event)
    else:
        state.early.append(event)


def _recommitted(before: Blame | None, now: Blame | None) -> bool:
    """Whether a sample holding the value a parameter had is a new commit of it (someone set
    the same value again: a later revision of the same life), not the same sample re-sent."""
    return before is not None and now is not None and now[4] > before[4]


def _blame_of(state: NodeState, s: StateSample) -> Blame:
    """The last change ``s`` carries, as the node's last one when it is the same change (see
    ``NodeState.shared_blame``)."""
    shared = state.shared_blame
    if shared is not None:
        stamp, blame = shared
        if (
            s.stamp == stamp
            and s.revision == blame[4]
            and s.who == blame[0]
            and s.via == blame[2]
            and s.verified == blame[1]
        ):
            return blame
    blame = (s.who, s.verified, s.via, round(s.stamp * 1e9), s.revision)
    state.shared_blame = (s.stamp, blame)
    return blame


def _delete(book: StateBook, state: NodeState, name: str) -> None:
    """A parameter instance disposed: gone from the state; ``deleted`` is emitted with the
    revision of the presence that follows (nothing for a name never held)."""
    if name not in state.parameters:
        return
    value, descriptor = state.parameters.pop(name)
    state.blame.pop(name, None)
    if book.has_callbacks:
        state.deleting.append((name, value, descriptor))


def _check_incarnation(
    book: StateBook, change: BookUpdate, state: NodeState, s: StateSample, info: Delivery
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
        _flush_deleted(change, state, state.revision)
        change.set_online(state, False)
    state.incarnation, state.shown = s.incarnation, 0
    if restarted and book.has_callbacks:
        _flush_deleted(change, state, state.revision)
        change.emit(
            MonitorEvent(
                EventKind.RESTARTED,
                state.node,
                revision=s.revision,
                stamp=time.time(),
                incarnation=s.incarnation,
                origin=state.origin,
            )
        )


def _flush_deleted(change: BookUpdate, state: NodeState, revision: int) -> None:
    for name, value, descriptor in state.deleting:
        change.emit(
            MonitorEvent(
                EventKind.DELETED,
                state.node,
                name,
                value,
                descriptor,
                change.shown(state, revision),
                time.time(),
                state.incarnation,
                origin=state.origin,
            )
        )
    state.deleting.clear()


def _apply_presence(change: BookUpdate, state: NodeState, s: StateSample, info: Delivery) -> None:
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
    change.set_status(state, status_of(tags))
    change.set_online(state, info.instance_state == InstanceState.Alive)
