"""The remote monitor's rules: what a gateway's node state and a liveliness token change.

Pure: :class:`RemoteStates` takes decoded states (:class:`~.codec.NodeStateMsg`) and
tokens seen or gone, and changes the monitor's book in the update it is given; asking
Zenoh for anything is :mod:`.monitor`'s. Its rules:

* per node, only the state with the highest ``seq`` of its gateway is held (a reply and
  a publication of one change may cross); a ``delta`` applies only on top of the state
  it follows (else the whole state must be asked for: :data:`GAP`);
* holding a state is an event per parameter added, modified or deleted since the state
  held before (none when nothing changed);
* a node is online while its gateway says so *and* its liveliness token is alive.

Every method runs inside an update of the book (its lock held), which guards this
object too.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from enum import Enum

from ..core.descriptors import ParameterDescriptor
from ..core.monitor_events import EventKind, MonitorEvent
from ..core.state_book import BookUpdate, StateBook
from ..core.values import ParameterValue
from .codec import NodeStateMsg

Table = dict[str, tuple[ParameterValue, ParameterDescriptor]]  # a node's parameters by name


class Outcome(Enum):
    HELD = "held"  # the state is the node's now
    OLD = "old"  # this state or a newer one is held already: nothing changed
    GAP = "gap"  # a delta that does not follow the state held: ask for the whole state


HELD, OLD, GAP = Outcome.HELD, Outcome.OLD, Outcome.GAP


class RemoteStates:
    """What the remote monitor knows besides the book: which state each node's gateway sent
    last, whether that gateway says the node is online, and whose tokens are alive."""

    def __init__(self) -> None:
        self._seen: dict[str, tuple[str, int]] = {}  # node -> (gateway, seq) of the state held
        self._reported: dict[str, bool] = {}  # node -> online as its gateway last said
        self._alive: set[str] = set()  # nodes whose liveliness token is alive
        self._gone: set[str] = set()  # nodes whose token was seen going (a first get may lag)

    def tokens_found(self, names: Iterable[str]) -> None:
        """The tokens a liveliness get found alive (those seen going since are not)."""
        self._alive.update(n for n in names if n not in self._gone)

    def token(self, change: BookUpdate, name: str, alive: bool) -> bool:
        """A node's token came (``alive``) or went; True when it came back after going."""
        came_back = False
        if alive:
            came_back = name in self._gone
            self._alive.add(name)
            self._gone.discard(name)
        else:
            self._alive.discard(name)
            self._gone.add(name)
        state = change.get(name)
        if state is not None:
            change.set_online(state, self._reported.get(name, False) and name in self._alive)
        return came_back

    def missing(self, change: BookUpdate) -> list[str]:
        """The nodes whose token is alive but whose state the book does not hold."""
        return [n for n in self._alive if change.get(n) is None]

    def apply(self, book: StateBook, change: BookUpdate, name: str, msg: NodeStateMsg) -> Outcome:
        """Apply the state (or delta) ``msg`` of node ``name`` (``SITE/NODE``)."""
        seen = self._seen.get(name)
        if seen is not None and seen[0] == msg.gateway and msg.seq <= seen[1]:
            return OLD
        parameters = msg.parameters
        if msg.kind == "delta":
            held = change.get(name)
            if held is None or seen != (msg.gateway, msg.base):
                return GAP
            parameters = {n: e for n, e in held.parameters.items() if n not in msg.deleted}
            parameters.update(msg.parameters)
        self._seen[name] = (msg.gateway, msg.seq)
        state = change.node(name)
        if book.has_callbacks:
            _changes(change, name, state.parameters, parameters, msg)
        state.parameters = dict(parameters)
        state.host, state.pid = msg.host, msg.pid
        state.revision, state.announced = msg.revision, msg.announced
        state.incarnation, state.origin = msg.incarnation, msg.origin
        self._reported[name] = msg.online
        change.set_status(state, msg.status)
        change.set_online(state, msg.online and name in self._alive)
        return HELD


def _changes(change: BookUpdate, name: str, old: Table, new: Table, msg: NodeStateMsg) -> None:
    """An event per parameter of ``name`` added, modified or deleted from ``old`` to ``new``."""
    stamp = time.time()
    for pname, (value, descriptor) in new.items():
        before = old.get(pname)
        if before is None:
            kind = EventKind.ADDED
        elif not before[0].same_as(value) or before[1] != descriptor:
            kind = EventKind.MODIFIED
        else:
            continue
        change.emit(MonitorEvent(kind, name, pname, value, descriptor, msg.revision, stamp, msg.incarnation))
    for pname, (value, descriptor) in old.items():
        if pname not in new:
            change.emit(
                MonitorEvent(
                    EventKind.DELETED, name, pname, value, descriptor, msg.revision, stamp, msg.incarnation
                )
            )
