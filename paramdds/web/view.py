"""Reading the monitor's state for the API without copying the whole system.

:meth:`ParameterMonitor.snapshot` copies every node's table (50,000 entries for
1,000 nodes x 50 parameters); a page of the node list needs 50 summaries and a
node view one node's rows. :class:`StateView` reads the monitor's live state
under its lock (through ``wait_until`` with a zero timeout, whose predicate sees
the live dict) and copies only what was asked for.

A node's revision is the larger of its presence instance's and the newest
revision carried by one of its events (:meth:`note_revision`) *of the same
incarnation*: the presence and the parameter samples of one change are separate
instances and may arrive in separate batches, and compare-and-set needs the newest.
A restarted server has a new incarnation and counts its revisions again (r9 after
r13): the view follows it instead of keeping the highest revision ever seen.

Over Zenoh the view also says which known sites it lacks (:meth:`StateView.lacking`,
from the session's :meth:`~paramdds.session.Session.missing_sites`), once the monitor's
first sync is done: before it, every site would read as lacking.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

from ..core.descriptors import ParameterDescriptor
from ..core.results import LastChange
from ..core.values import ParameterValue
from ..dds.client import NodeInfo
from .model import matches

if TYPE_CHECKING:
    from ..dds.monitor import NodeState, ParameterMonitor
    from ..zenoh.completeness import Lack

T = TypeVar("T")
Table = dict[str, tuple[ParameterValue, ParameterDescriptor]]
Lacking = dict[str, str]  # a site the view lacks: {"site", "status" ("no answer", "not granted"), "reason"}


@dataclass(frozen=True)
class NodePage:
    total: int  # nodes matching the query
    offset: int
    nodes: list[NodeInfo]


@dataclass(frozen=True)
class NodeDetail:
    summary: NodeInfo
    parameters: Table
    last_changes: dict[str, LastChange] = field(default_factory=dict)  # who last changed each, if said


def held_last_changes(st: NodeState) -> dict[str, LastChange]:
    """Who last changed each parameter of ``st``, as the monitor holds it (from the state samples)."""
    return {name: lc for name in st.parameters if (lc := st.last_change(name)) is not None}


class StateView:
    def __init__(self, monitor: ParameterMonitor | None = None) -> None:
        self._monitor = monitor
        self._missing: Callable[[], dict[str, Lack]] | None = None
        self._revisions: dict[str, tuple[int, int]] = {}  # node -> (incarnation, newest revision)
        self._lock = threading.Lock()

    def attach(self, monitor: ParameterMonitor, missing: Callable[[], dict[str, Lack]] | None = None) -> None:
        """Read ``monitor`` from now on (it is made after the hub that receives its events);
        ``missing``: the sites it lacks, and why (over Zenoh)."""
        self._monitor = monitor
        self._missing = missing

    @property
    def follows_sites(self) -> bool:
        """Whether this view says which sites it lacks (over Zenoh)."""
        return self._missing is not None

    def lacking(self) -> list[Lacking]:
        """The known sites this view lacks, by site (none over DDS, and until the first sync)."""
        if self._missing is None or self._monitor is None or not self._monitor.synced:
            return []
        return [
            {"site": site, "status": lack.status, "reason": lack.reason}
            for site, lack in sorted(self._missing().items())
        ]

    def note_revision(self, node: str, revision: int, incarnation: int = 0) -> None:
        with self._lock:
            seen = self._revisions.get(node)
            if seen is None or seen[0] != incarnation or revision > seen[1]:
                self._revisions[node] = (incarnation, revision)

    def _peek(self, fn: Callable[[dict[str, NodeState]], T]) -> T:
        out: list[T] = []
        if self._monitor is None:
            return fn({})

        def take(states: dict[str, NodeState]) -> bool:
            out.append(fn(states))
            return True

        self._monitor.wait_until(take, 0.0)
        return out[0]

    def _summary(self, st: NodeState) -> NodeInfo:
        revision = st.revision
        with self._lock:
            seen = self._revisions.get(st.node)
        if seen is not None and seen[0] == st.incarnation:  # events of another incarnation do not count
            revision = max(revision, seen[1])
        return NodeInfo(
            st.node,
            st.online,
            st.host,
            st.pid,
            revision,
            len(st.parameters),
            st.request_filter,
            st.incarnation,
            st.origin,
            st.status,
        )

    def page(self, query: str, offset: int, limit: int) -> NodePage:
        def build(states: dict[str, NodeState]) -> NodePage:
            names = sorted(n for n, st in states.items() if matches(query, n, st.parameters))
            shown = [self._summary(states[n]) for n in names[offset : offset + limit]]
            return NodePage(len(names), offset, shown)

        return self._peek(build)

    def summaries(self, nodes: list[str]) -> list[NodeInfo]:
        def build(states: dict[str, NodeState]) -> list[NodeInfo]:
            return [self._summary(states[n]) for n in nodes if n in states]

        return self._peek(build)

    def detail(self, node: str) -> NodeDetail | None:
        def build(states: dict[str, NodeState]) -> NodeDetail | None:
            st = states.get(node)
            if st is None:
                return None
            return NodeDetail(self._summary(st), dict(st.parameters), held_last_changes(st))

        return self._peek(build)
