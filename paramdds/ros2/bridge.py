"""``paramdds ros2``: the long-lived bridge between a ROS 2 graph and a paramdds domain.

One loop, every :data:`POLL` seconds (:data:`POLL_SEEKING` while a ROS 2 process does not
answer or a node that left stalled is looked for, and at once when a stalled process
answers), reads the ROS 2 graph (node names and enclaves, ``/parameter_events`` writers)
and the paramdds presence, and decides:

* **mirrored**: a ROS 2 node matching the mirror globs, not of the bridge enclave
  (the bridge itself, the nodes any bridge exposes) and not already on paramdds from
  another process. It is hosted by the bridge's ParameterServer with the presence
  tag ``origin=ros2``; it goes offline when it leaves the ROS 2 graph. One whose
  parameter services do not answer is hosted meanwhile by a second server whose presence
  also says ``status=unreachable`` (see :mod:`.mirror`).
* **exposed**: a paramdds node matching the expose globs that is not a mirror
  (``origin`` unset) and not a ROS 2 node. See :mod:`.expose`.

A node is never both: a mirror carries ``origin=ros2`` and is never exposed, an exposed
node lives in the bridge enclave and is never mirrored, and a ROS 2 node that some
process already hosts on paramdds is left alone. So two bridges never loop a node.
"""

from __future__ import annotations

import fnmatch
import logging
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from cyclonedds.domain import DomainParticipant

from ..core.hosted import HostedTable
from ..core.names import canonical_node_id
from ..dds.client import ParameterClient
from ..dds.filters import STALE, origin_tag, status_tag
from ..dds.qos import QosProfiles
from ..dds.server import ParameterServer
from ..dds.transport import SecureTransport, transport_of
from ..errors import NotPermittedError, ParamddsError
from .liveness import STALE_AFTER, Liveness
from .mirror import UNREACHABLE, Mirror, MirrorTable
from .rosside import ENCLAVE, RosSide

SECURE_REFUSED = (
    "the ROS 2 bridge does not run in secure mode (--identity, PARAMDDS_IDENTITY): a secure "
    "server is created with the node ids it will host, and the bridge hosts whatever ROS 2 "
    "nodes appear; run it without an identity, on a domain without DDS Security"
)

log = logging.getLogger(__name__)

POLL = 0.5  # seconds between looks at the ROS 2 graph and the paramdds presence
# ... while a ROS 2 process is shown stalled or a node that left stalled is looked for: what
# a starved bridge must run for, from a process's resuming to its nodes mirrored, is mostly
# looks (docs/ros2.md: the stall figures)
POLL_SEEKING = 0.25
START_WAIT = 3.0  # seconds at most a start waits to learn what paramdds already holds
ORIGIN = "ros2"


@dataclass
class BridgeOptions:
    mirror: Sequence[str] = ("*",)  # fqn globs of ROS 2 nodes to mirror
    exclude: Sequence[str] = ()  # fqn globs never mirrored
    expose: Sequence[str] = ()  # paramdds node globs to expose to ROS 2 (none by default)
    timeout: float = 5.0  # seconds a ROS 2 call waits with no caller's deadline (reads, assignments)
    resync: float = 60.0  # seconds between full re-reads of each mirrored node (0: never)
    ros_domain: int | None = None  # ROS_DOMAIN_ID when None
    name: str = "paramdds_bridge"
    extra: dict[str, Any] = field(default_factory=dict)


def matches(fqn: str, include: Sequence[str], exclude: Sequence[str]) -> bool:
    """Whether a node (``/ns/name``) is selected by the globs (``*`` matches ``/`` too)."""
    forms = (fqn, fqn.lstrip("/"))
    hit = any(fnmatch.fnmatchcase(f, g) for g in include for f in forms)
    return hit and not any(fnmatch.fnmatchcase(f, g) for g in exclude for f in forms)


class Bridge:
    """Mirror ROS 2 nodes on paramdds and expose paramdds nodes to ROS 2 until :meth:`close`."""

    def __init__(
        self, participant: DomainParticipant, qos: QosProfiles | None, options: BridgeOptions
    ) -> None:
        if isinstance(transport_of(participant), SecureTransport):  # before anything starts (rclpy included)
            raise NotPermittedError(SECURE_REFUSED)
        self.options = options
        self._qos = qos or QosProfiles.load()
        self.ros = RosSide(options.ros_domain, options.name)
        self.server = ParameterServer(participant, self._qos, tags=[origin_tag(ORIGIN)])
        self.client = ParameterClient(participant, self._qos)
        self._participant = participant
        self._unreachable: ParameterServer | None = None  # made when a node first needs it
        self._unreachable_lock = threading.Lock()
        self.mirror = Mirror(
            self.ros,
            self._host,
            self._unhost,
            self.server.forget,
            timeout=options.timeout,
            resync=options.resync,
            show_unreachable=self._show_unreachable,
            hide_unreachable=self._hide_unreachable,
        )
        self._wake = threading.Event()  # the loop looks now: a stalled process answered, or close()
        self.liveness = Liveness(on_answer=self._wake.set)
        self._seeking = False  # a process is shown stalled, or a node that left stalled is looked for
        self._unsaid: dict[str, MirrorTable] = {}  # node id -> back to ok, presence not written yet
        self._last_step: float | None = None
        self.exposer: Any = None
        if options.expose:
            from .expose import Exposer

            self.exposer = Exposer(self.ros, participant, self._qos, options.timeout)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._seen: tuple[int, int, int] = (-1, -1, -1)  # what step() logged last (see there)

    def start(self) -> Bridge:
        self.server.start()
        self._thread = threading.Thread(target=self._run, name="paramdds-ros2-bridge", daemon=True)
        self._thread.start()
        return self

    def _unhost(self, node_id: str) -> None:
        """Stop hosting a mirror; one that a concurrent resynchronization took down already is
        no error (it raised KeyError out of the bridge's loop)."""
        try:
            self.server.remove_node(node_id)
        except KeyError:
            log.debug("%s was not hosted any more", node_id)

    def _host(self, table: MirrorTable) -> None:
        """Host a mirrored node: the values it had when first read are its own (who: the node,
        via ros2, unverified), not start values of the bridge's."""
        snapshot = ((name, value) for name, value, _ in table.snapshot())
        self.server.history(table.node_id).started(snapshot, table.revision, table.reported, time.time_ns())
        self.server.add_node(table)

    def _show_unreachable(self, table: HostedTable) -> None:
        """Host a node whose services do not answer, with ``status=unreachable`` in its presence."""
        with self._unreachable_lock:
            if self._unreachable is None:
                tags = [origin_tag(ORIGIN), status_tag(UNREACHABLE)]
                self._unreachable = ParameterServer(self._participant, self._qos, tags=tags).start()
            if table.node_id not in self._unreachable.nodes:
                self._unreachable.add_node(table)

    def _hide_unreachable(self, node_id: str) -> None:
        with self._unreachable_lock:
            if self._unreachable is not None and node_id in self._unreachable.nodes:
                self._unreachable.remove_node(node_id)

    @property
    def unreachable(self) -> list[str]:
        """The node ids shown unreachable now."""
        with self._unreachable_lock:
            return [] if self._unreachable is None else sorted(self._unreachable.nodes)

    def _run(self) -> None:
        # learn what paramdds already holds before mirroring anything (never host a node
        # twice): every other server found has delivered its presence and discovery is quiet.
        # Our own server hosts nothing yet, and "no other server" is an answer (waiting for
        # one, as a client's `settled` does, cost every start the whole 3 s bound).
        self.client.ignore_writer(self.server.publication.writer)
        deadline = time.monotonic() + START_WAIT
        while not self._stop.is_set() and not self.client.discovery().quiet and time.monotonic() < deadline:
            self._stop.wait(0.05)
        while not self._stop.is_set():
            try:
                self.step()
            except Exception:
                log.exception("the bridge loop failed; trying again")
            self._wake.wait(POLL_SEEKING if self._seeking else POLL)
            self._wake.clear()

    def step(self) -> None:
        """One look at both graphs (the loop's body)."""
        graph = self.ros.graph()
        writers = self.ros.event_publishers()
        # seen by a participant its process never knew, not by ours (see Mirror.found_again)
        found = self.mirror.found_again(graph, time.monotonic())
        for fqn, gids in self.mirror.returning(graph, writers).items():
            # back from a stall past the lease, unnamed in ROS 2's graph (see Mirror.returning);
            # it was mirrored before, so it is not of the bridge enclave
            graph[fqn], writers[fqn] = "", gids
        for fqn, (enclave, gids) in found.items():
            graph[fqn], writers[fqn] = enclave, gids
        listed = self.client.nodes()
        # Ours: every node the mirror holds, hosted or not at this instant, taken after the
        # listing. A mirror being hosted, or hosted again after a restart, is online in the
        # listing before (or still, while it is being taken down) it is in the server's
        # nodes; counted as "another process's" it was dropped and added again, over and over
        # while a start hosted 100 nodes (CI: '0 of 100 mirrored').
        ours = {*self.mirror.node_ids(), *self.server.nodes, *self.unreachable}
        on_paramdds = {info.node: info for info in listed if info.online and info.node not in ours}
        wanted: dict[str, frozenset[bytes]] = {}
        elsewhere = 0  # selected, but already on paramdds from another process
        for fqn, enclave in graph.items():
            if enclave == ENCLAVE or not matches(fqn, self.options.mirror, self.options.exclude):
                continue
            try:
                if canonical_node_id(fqn) in on_paramdds:
                    elsewhere += 1
                    continue
            except ParamddsError:
                continue
            wanted[fqn] = writers.get(fqn, frozenset())
        seen = (len(graph), len(wanted), elsewhere)
        if seen != self._seen:  # what a start that mirrors nothing needs said (--log-level info)
            self._seen = seen
            log.info(
                "the ROS 2 graph has %d nodes: %d to mirror, %d selected but hosted on paramdds by "
                "another process",
                *seen,
            )
        now = time.monotonic()
        self.mirror.update(wanted, now)
        self._show_stalls(now)
        if self.exposer is not None and self.mirror.knows_graph(now):
            # a name taken in ROS 2 by anyone but this bridge's own exposed nodes (a ROS 2
            # node, or another bridge's exposure of the same paramdds node) is not exposed;
            # nothing is exposed before the graph is known (a name not seen yet may be taken)
            ros_nodes = {f.lstrip("/") for f in graph} - set(self.exposer.nodes)
            exposed = {
                node: info
                for node, info in on_paramdds.items()
                if info.origin is None
                and node not in ros_nodes
                and matches("/" + node, self.options.expose, ())
            }
            self.exposer.update(exposed)

    def _show_stalls(self, now: float) -> None:
        """Show ``stale`` the mirrors of the ROS 2 processes that do not answer (see
        :mod:`.liveness`), and ``ok`` again once they do: the table's ``status``, which every
        presence sample of the node carries. Back to ok while a forwarded set is out, the
        presence is written once the set has returned (the server shows a set out past its
        lease stale, and writes the presence when it returns)."""
        if self._last_step is not None and now - self._last_step > POLL + STALE_AFTER:
            self.liveness.excuse(now)  # we did not run: the probes out are not late
        self._last_step = now
        groups = self.mirror.by_process()
        stalled = self.liveness.update({p: {m.fqn: m.link.ros for m in ms} for p, ms in groups.items()}, now)
        self.mirror.stalls(stalled, now)
        self._seeking = bool(stalled) or self.mirror.looking()
        hosted = self.server.nodes
        for prefix, mirrors in groups.items():
            status = STALE if prefix in stalled else None
            for m in mirrors:
                table = m.table
                if hosted.get(m.node_id) is not table or table.status == status:
                    continue
                table.status = status
                self._unsaid[m.node_id] = table
        for node_id, table in list(self._unsaid.items()):
            if hosted.get(node_id) is not table:  # gone, or hosted afresh: its presence is new
                del self._unsaid[node_id]
            elif table.status is not None or not table.forwarding:
                self.server.publication.write_presence(table)
                del self._unsaid[node_id]

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self.liveness.close()
        if self.exposer is not None:
            self.exposer.close()
        self.mirror.close()
        with self._unreachable_lock:
            if self._unreachable is not None:
                self._unreachable.close()
        self.server.close()
        self.client.close()
        self.ros.close()

    def __enter__(self) -> Bridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
