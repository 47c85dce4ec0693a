"""What a monitor tells and holds, whatever feeds it: its events and each node's state.

:class:`MonitorEvent` is one change a monitor saw (its kind an :class:`EventKind`);
:class:`NodeState` is what a monitor holds of one node, with each parameter's last change
(who made it, whether verified, through what, when, at which revision) as a :data:`Blame`
(a plain tuple: making a :class:`~.results.LastChange` costs ~1 µs, a third of decoding a
sample, and a monitor that joins a fleet holds 200,000). Both are plain data: the rules
that produce them are the feeds' (:mod:`paramdds.dds.monitor_rules` over DDS,
:mod:`paramdds.zenoh.monitor` over Zenoh), the book that keeps them is
:class:`~paramdds.core.state_book.StateBook`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

from .descriptors import ParameterDescriptor
from .names import shown_node
from .results import LastChange
from .values import ParameterValue

# A parameter's last change as a monitor holds it: who, verified, via, time (nanoseconds
# since the epoch), revision (the fields of LastChange, in its order)
Blame = tuple[str, bool, str, int, int]


def last_change_of(blame: Blame | None) -> LastChange | None:
    """The :class:`LastChange` a :data:`Blame` says; None when it is unknown (no blame, or no author)."""
    if blame is None or not blame[0]:
        return None
    return LastChange(*blame)


class EventKind(str, Enum):
    ADDED = "added"
    MODIFIED = "modified"
    DELETED = "deleted"
    ONLINE = "online"
    OFFLINE = "offline"
    RESTARTED = "restarted"  # the node's server started again (a new incarnation)
    STATUS = "status"  # an online node's status changed (NodeState.status; None: back to normal)
    # every gateway of a site went (killed, or its uplink cut), taking all its nodes offline, and
    # a gateway of it came back: one event for the site (MonitorEvent.site; node is "")
    SITE_OFFLINE = "site_offline"
    SITE_ONLINE = "site_online"
    # every gateway of a site went, and the site is held a few seconds before it is offline: its
    # online nodes show status "stale" (MonitorEvent.status "stale"), then normal again (status None)
    # when a gateway is back in time (their own status events marked by_site)
    SITE_STATUS = "site_status"
    SYNCED = "synced"


@dataclass(frozen=True)
class MonitorEvent:
    """A change a monitor saw: a parameter's new state, a node going on or offline, or
    (over Zenoh) a whole site."""

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
    site: str = ""  # the site of a site_offline / site_online / site_status event (remote monitors only)
    # an online / offline / status event of a node that came or went with its whole site: the site's
    # event says it once, so a log shows one line, not one per node
    by_site: bool = False
    # added / modified: who made the change, whether verified, through what, when, at which
    # revision (None when the writer keeps no blame, and on every other kind)
    last_change: LastChange | None = None


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
    # each parameter's last change, where its writer said it (see last_change)
    blame: dict[str, Blame] = field(default_factory=dict)
    # the last Blame a feed made for this node and the writer's stamp it was made from: the
    # parameters of one change share it (a monitor joining a fleet receives each node's table
    # written by one change: 200,000 tuples of which 10,000 differ cost its sync)
    shared_blame: tuple[float, Blame] | None = None
    shown: int = 0  # the highest revision an event showed for this incarnation
    # deletions waiting for the presence sample that gives their revision (see paramdds.dds.monitor_rules)
    deleting: list[tuple[str, ParameterValue, ParameterDescriptor]] = field(default_factory=list)
    # events of a node whose presence has not arrived yet: emitted with it, once its origin is known
    early: list[MonitorEvent] = field(default_factory=list)

    def last_change(self, name: str) -> LastChange | None:
        """Who last changed parameter ``name``, when, through what; None when unknown."""
        return last_change_of(self.blame.get(name))

    @property
    def complete(self) -> bool:
        """True when this monitor holds every parameter the node announced."""
        return self.announced == len(self.parameters)

    @property
    def shown_name(self) -> str:
        """The node as the CLI and the web console write it (``"node"`` in ``paramdds nodes -o
        json``): a mirrored ROS 2 node with its leading slash (``/synth/node_050``, its key
        ``synth/node_050``), any other node as its key."""
        return shown_node(self.node, self.origin)


EventCallback = Callable[[MonitorEvent], None]
