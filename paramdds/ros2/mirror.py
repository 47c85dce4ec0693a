"""ROS 2 nodes mirrored on paramdds: each one a :class:`MirrorTable` hosted by a ParameterServer.

The server does everything it does for a native node (state and presence samples,
requests, dedup of retries, per-node workers, stall detection); only the table is
different. Reads (get, list, describe) are answered from what the table holds. A set
or atomic set goes through the server's commit path to :meth:`MirrorTable.set`, which
forwards it to the ROS 2 node's own service (from the node's worker, bounded by a
timeout: a node hanging in a callback delays only its own requests) and commits what
the node accepted with :meth:`ParameterTable.mirror`, so the server publishes it like
any change. Changes made in ROS 2 arrive on ``/parameter_events`` and are committed
the same way. A MirrorTable is not a ParameterTable: it holds one (what is known of the
node) and is hosted through the :class:`~paramdds.core.hosted.HostedTable` protocol, as
an :class:`UnreachableTable` is.

Every commit is stamped (:mod:`paramdds.core.origin`): what the ROS 2 node reports (its
events, a read) with ``who`` = the node's name (``/talker``), ``via`` ros2, unverified (ROS 2
says which node changed, never who asked it to); a set forwarded from paramdds with its
asker's origin, also when the node's event for it arrives before its answer.

A node is read in full (list, get, describe) when it appears, restarts, or DDS reports
lost ``/parameter_events`` samples. Periodically (``resync`` seconds) only its values are
checked (:meth:`Mirror._check`: one ``get_parameters``), paced over the period
(:meth:`Mirror._due_checks`): the events carry every change, the check repairs what they
may have missed.

Compare-and-set is refused: ROS 2 has no revision, so the check and the set could
never be one step (another ROS 2 client may set in between).

A node whose parameter services do not answer the first read (not matched: the node
has none, or discovery went wrong) is read again after :data:`RETRY` seconds, from the
second failure on with new clients (new DDS endpoints, discovered afresh), and from the
:data:`RESCUE_AT`-th on through a new DDS participant (another rclpy context, shared by
such nodes; see :meth:`Mirror._rescue_side`). After :data:`UNREACHABLE_AFTER` seconds of
failing it is shown on paramdds as ``status=unreachable`` (an :class:`UnreachableTable`:
no parameters, every request refused with UNAVAILABLE), until a read succeeds. After
:data:`FAST_TRIES` failures the retries slow down (up to 30 s apart), so a node that
really has no parameter services does not churn the graph's endpoints.

A node that comes back after its process stalled past Fast DDS's participant lease may
stay out of ROS 2's graph for good: its peers drop the participant, rediscover its
endpoints when it resumes, but never receive its ``ros_discovery_info`` again (the
stalled side never dropped them, and Fast DDS's reliable repair does not resend to a
reader it still counts as up to date), so rmw names its endpoints' node
``_NODE_NAME_UNKNOWN_``. A ``/parameter_events`` writer is one writer of one node of one
process: the mirror remembers the writers of the nodes that left (:data:`REMEMBERED`),
and one that reappears unnamed brings its node back (:meth:`Mirror.returning`), mirrored at
once (the same process, never a tool's node).

That needs the bridge's participant to rediscover the resumed process at all; a bridge
stopped or starved itself while the process resumed may not, and its graph then lacks the
nodes for good. So a node whose process did not answer as it left (a stall past the lease;
a crash too, which never comes back) is looked for, :data:`LOOK_FOR` seconds, through a
participant its process never knew (:meth:`Mirror.found_again`): made after it stopped
answering and that never saw it before it left, or else made after it left. The resumed
process and that participant discover each other afresh. Such a participant is made as
soon as a process has not answered for :data:`READY_AFTER` seconds (:meth:`Mirror.stalls`),
so that it has discovered the rest of the graph before the lease runs out, and finds the
process at its first announcement when it resumes. A node found so, or back unnamed
while such a participant exists (the bridge's participant may have rediscovered only part
of the process), is mirrored through that participant (its services called, its
``/parameter_events`` read there: one subscription per such participant) until the
bridge's own participant lists it again. A node back with a writer it had when it left is its
process resumed: it is hosted at once with what it held as it left, and its values checked
(:meth:`Mirror._resume`), not read in full.

The opposite also happens: a process that stops destroys its nodes one by one, each one an
update of its node list (``ros_discovery_info``, reliable, keep-last 1) and the removal of the
node's endpoints (DDS discovery). When the process exits before its last updates reached the
bridge, and its goodbye is lost too, the later nodes keep their names in rmw's graph, without
an endpoint, until the participant's lease (20 s); for good when a node list of the process is
processed after the process was dropped (rmw_dds_common's graph cache adds it back). A
mirrored node still named whose ``/parameter_events`` writer has been gone for
:data:`UNLISTED_FOR` seconds has left (:meth:`Mirror._unlisted`); it is kept out while the name
lingers without a writer, and a node of that name with a writer is mirrored as a new one.
"""

from __future__ import annotations

import contextlib
import logging
import random
import threading
from collections import Counter, OrderedDict, deque
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

from ..core import deadline as deadlines
from ..core import origin as origins
from ..core.descriptors import ParameterDescriptor
from ..core.fit import fit_value
from ..core.hosted import HostedTable
from ..core.limits import check_request_size
from ..core.names import canonical_node_id, is_valid_name
from ..core.origin import Origin, Via
from ..core.results import ChangeSet, GetResult, ListResult, SetOutcome, SetResult
from ..core.table import ParameterTable
from ..core.values import Parameter, ParameterType, ParameterValue
from ..errors import ErrorCode, InvalidValueError, OutcomeUnknownError, ParamddsError, TooLargeError
from .liveness import process_of
from .messages import descriptor_from_ros, parameter_to_ros, result_from_ros, value_from_ros
from .rosside import RosSide, Unanswered, fqn_of

log = logging.getLogger(__name__)

RETRY = 1.0  # seconds between reads of a node that was never read, for its first FAST_TRIES failures
FAST_TRIES = 8
UNREACHABLE_AFTER = 3.0  # seconds of failing reads before a node is shown unreachable
RESCUE_AT = 3  # the failure from which the node's clients live in a new participant
RESCUE_EVERY = 10.0  # seconds: a new rescue participant at most this often
UNREACHABLE = "unreachable"
MIN_AGE = 2.0  # seconds a node must have been in the graph before it is mirrored (not tool nodes)
RESYNC_SPREAD = 0.25  # a node's next resync is due after 75-100 % of the period, drawn at each sync
PACE_SLACK = 0.5  # seconds of checks that fell behind (one look of the bridge) made up at once
# seconds from the bridge's first look during which the nodes found were there before it:
# Fast DDS finds the participants of a running graph 0.2-3.3 s after its start (measured
# with a bare rclpy node against 4 host processes: a peer that misses the first
# announcements answers at its next periodic one, every 3 s)
START_WINDOW = 4.0
# rmw's name for the node of an endpoint whose participant's node list it does not have
UNKNOWN_NODE = fqn_of("_NODE_NAME_UNKNOWN_", "_NODE_NAMESPACE_UNKNOWN_")
REMEMBERED = 4096  # /parameter_events writers of nodes that left, remembered (the newest)
LOOK_FOR = 600.0  # seconds a node that left stalled is looked for through a participant new to it
MAX_RESCUES = 4  # rescue participants alive at once (each an rclpy context that discovers the whole graph)
# seconds a process has not answered before a rescue participant is made for it (see Mirror.stalls):
# ready, with the rest of the graph discovered, when it stalls past its lease and resumes
READY_AFTER = 5.0

Entry = tuple[ParameterValue, ParameterDescriptor]
READS = ("list_parameters", "get_parameters", "describe_parameters")  # clients made per read (see RosLink)
UNLISTED = "is still named in the ROS 2 graph, without its /parameter_events writer"
# seconds a mirrored node's name must be in the graph without its writer before it is taken as
# gone: a node being destroyed loses it a few ms before its name (a look of the bridge's fell
# there in 1 of 17 clean stops of a 20-node host)
UNLISTED_FOR = 1.0
CAS_REFUSED = (
    "compare-and-set is not available on a mirrored ROS 2 node: ROS 2 has no revision, so the "
    "check and the set could not be one step; set without an expected revision"
)


class RosLink:
    """The parameter services of one ROS 2 node, called with a bounded timeout."""

    def __init__(self, ros: RosSide, fqn: str, timeout: float) -> None:
        self.ros = ros
        self.fqn = fqn
        self.timeout = timeout
        self._clients: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._reading = 0  # reads in progress (see _reads)
        self.calls: Counter[str] = Counter()  # service calls made, by service (for tests and figures)

    @contextlib.contextmanager
    def _reads(self) -> Iterator[None]:
        """Around the reads of the node: its read clients live only while one is in progress.

        rclpy's executor rebuilds its wait set from every client of the bridge's node on each
        wake-up, in Python: three idle read clients per mirrored node made every forwarded set
        and every reply slower the more nodes were mirrored (7 ms a set at N = 300), and the
        bridge's own paramdds answers waited for the interpreter meanwhile."""
        with self._lock:
            self._reading += 1
        try:
            yield
        finally:
            with self._lock:
                self._reading -= 1
                idle = [] if self._reading else [self._clients.pop(s) for s in READS if s in self._clients]
                ros = self.ros
            self._destroy(ros, idle)

    def _client(self, service: str) -> Any:
        from rcl_interfaces import srv

        kinds = {
            "list_parameters": srv.ListParameters,
            "get_parameters": srv.GetParameters,
            "describe_parameters": srv.DescribeParameters,
            "set_parameters": srv.SetParameters,
            "set_parameters_atomically": srv.SetParametersAtomically,
        }
        with self._lock:
            client = self._clients.get(service)
            if client is None:
                client = self._clients[service] = self.ros.client(kinds[service], f"{self.fqn}/{service}")
        return client

    def _call(self, service: str, request: Any, timeout: float | None = None) -> Any:
        self.calls[service] += 1
        return self.ros.call(self._client(service), request, self.timeout if timeout is None else timeout)

    def fetch(self) -> dict[str, Entry]:
        """Every parameter of the node with its value and descriptor (list, get, describe)."""
        from rcl_interfaces import srv

        with self._reads():
            for service in ("get_parameters", "describe_parameters"):
                self._client(service)  # created now, they match the node's services while we list
            listed = self._call("list_parameters", srv.ListParameters.Request(depth=0))
            names = sorted(set(listed.result.names))
            return self.entries(names)

    def entries(self, names: Sequence[str]) -> dict[str, Entry]:
        """Value and descriptor of ``names`` (those the node no longer has are left out)."""
        from rcl_interfaces import srv

        if not names:
            return {}
        with self._reads():
            got = self._call("get_parameters", srv.GetParameters.Request(names=list(names)))
            described = self._call("describe_parameters", srv.DescribeParameters.Request(names=list(names)))
        if len(got.values) != len(names) or len(described.descriptors) != len(names):
            raise ParamddsError(
                f"{self.fqn} answered {len(got.values)} values and {len(described.descriptors)} "
                f"descriptors for {len(names)} names (a parameter went away meanwhile?)",
                code=ErrorCode.CONFLICT,
            )
        return {
            name: (value_from_ros(v), descriptor_from_ros(d, name))
            for name, v, d in zip(names, got.values, described.descriptors, strict=True)
        }

    def values(self, names: Sequence[str]) -> list[ParameterValue]:
        """The node's values of ``names``, in order (NOT_SET for one it does not have): one call."""
        from rcl_interfaces import srv

        with self._reads():
            got = self._call("get_parameters", srv.GetParameters.Request(names=list(names)))
        if len(got.values) != len(names):
            raise ParamddsError(
                f"{self.fqn} answered {len(got.values)} values for {len(names)} names",
                code=ErrorCode.CONFLICT,
            )
        return [value_from_ros(v) for v in got.values]

    def set(self, params: Sequence[Parameter], atomic: bool, deadline: int = 0) -> list[SetResult]:
        """Forward a set; one result per parameter, in order, with ROS 2's reasons and our codes.

        Waits for the node until ``deadline`` (the paramdds caller's, ns since the epoch; 0: the
        link's timeout) at most: see :func:`forward_budget`."""
        from rcl_interfaces import srv

        budget = forward_budget(self.timeout, deadline)
        msgs = [parameter_to_ros(p.name, p.value) for p in params]  # type: ignore[arg-type]
        if atomic:
            reply = self._call(
                "set_parameters_atomically", srv.SetParametersAtomically.Request(parameters=msgs), budget
            )
            one = reply.result
            return [result_from_ros(p.name, one) for p in params]
        reply = self._call("set_parameters", srv.SetParameters.Request(parameters=msgs), budget)
        if len(reply.results) != len(params):
            raise ParamddsError(
                f"{self.fqn} answered {len(reply.results)} results for {len(params)} parameters",
                code=ErrorCode.INTERNAL,
            )
        return [result_from_ros(p.name, r) for p, r in zip(params, reply.results, strict=True)]

    def close(self) -> None:
        with self._lock:
            clients, self._clients = list(self._clients.values()), {}
            ros = self.ros
        self._destroy(ros, clients)

    def _destroy(self, ros: RosSide, clients: Sequence[Any]) -> None:
        for client in clients:
            try:
                ros.destroy_client(client)
            except Exception:
                log.debug("destroying a client of %s failed", self.fqn, exc_info=True)

    def renew(self, ros: RosSide | None = None) -> None:
        """New clients next time (new DDS endpoints), made by ``ros`` when given (a new participant)."""
        self.close()
        if ros is not None:
            with self._lock:
                self.ros = ros


class _Held:
    """A :class:`HostedTable` whose state is a plain :class:`ParameterTable` (``held``):
    reads and change listeners are the held table's; what a set does is the subclass's."""

    forwards_writes = False

    def __init__(self, node_id: str) -> None:
        self.node_id = node_id
        self.held = ParameterTable(node_id)

    @property
    def revision(self) -> int:
        return self.held.revision

    def __len__(self) -> int:
        return len(self.held)

    def has(self, name: str) -> bool:
        return self.held.has(name)

    def names(self) -> list[str]:
        return self.held.names()

    def snapshot(self) -> list[tuple[str, ParameterValue, ParameterDescriptor]]:
        return self.held.snapshot()

    def get_many(self, names: Sequence[str], *, with_descriptors: bool = False) -> list[GetResult]:
        return self.held.get_many(names, with_descriptors=with_descriptors)

    def list(self, prefixes: Sequence[str] = (), depth: int = 0) -> ListResult:
        return self.held.list(prefixes, depth)

    def try_locked(self) -> contextlib.AbstractContextManager[bool]:
        return self.held.try_locked()

    def add_change_listener(self, fn: Callable[[ChangeSet], None]) -> object:
        return self.held.add_change_listener(fn)

    def remove_change_listener(self, handle: object) -> None:
        self.held.remove_change_listener(handle)


class UnreachableTable(_Held):
    """What paramdds holds of a ROS 2 node whose parameter services do not answer: no
    parameters, and every request refused with UNAVAILABLE (never "not declared")."""

    def __init__(self, node_id: str, fqn: str) -> None:
        super().__init__(node_id)
        self.reason = (
            f"the ROS 2 node {fqn} is in the graph but its parameter services do not answer "
            "(the bridge keeps trying)"
        )

    def _refuse(self) -> ParamddsError:
        return ParamddsError(self.reason, code=ErrorCode.UNAVAILABLE)

    def get_many(self, names: Sequence[str], *, with_descriptors: bool = False) -> list[GetResult]:
        raise self._refuse()

    def list(self, prefixes: Sequence[str] = (), depth: int = 0) -> ListResult:
        raise self._refuse()

    def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome:
        raise self._refuse()

    def set_atomically(
        self, params: Sequence[Parameter], *, expected_revision: int | None = None
    ) -> SetOutcome:
        raise self._refuse()


class MirrorTable(_Held):
    """The table of a mirrored ROS 2 node: reads are local, sets go to the node first.

    Its reads never wait for a forwarded set (``forwards_writes``): while the node is stalled
    they are answered from what the table holds, and the node shows ``status=stale``. What
    the node accepted, and what its events and reads say, is committed to the held table
    with :meth:`ParameterTable.mirror`, under a lock of this table's, so that what is held
    cannot change between reading it and committing what is derived from it."""

    forwards_writes = True

    def __init__(self, node_id: str, link: RosLink) -> None:
        super().__init__(node_id)
        self.link = link
        self._commits = threading.Lock()
        # the node's own reports are stamped with its name (see the module docstring)
        self.reported = Origin(link.fqn, Via.ROS2, verified=False)
        # sets forwarded and not yet answered: (their origin, what they set); the node's event
        # for one may arrive first, and is then committed with the forwarded set's origin
        self._forwarding: list[tuple[Origin, dict[str, ParameterValue]]] = []
        # "stale" while the node's process does not answer (set by the bridge, see .liveness):
        # every presence sample of the node says so, whoever writes it
        self.status: str | None = None

    @property
    def forwarding(self) -> bool:
        """Whether a forwarded set waits on the node now."""
        with self._commits:
            return bool(self._forwarding)

    def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome:
        return self._forward(params, expected_revision, atomic=False)

    def set_atomically(
        self, params: Sequence[Parameter], *, expected_revision: int | None = None
    ) -> SetOutcome:
        return self._forward(params, expected_revision, atomic=True)

    def _forward(
        self, params: Sequence[Parameter], expected_revision: int | None, atomic: bool
    ) -> SetOutcome:
        request, refused = self._screen(params)
        deadline = deadlines.current()  # the paramdds caller's (0 for an assignment)
        deadlines.check(deadline)  # not forwarded once its caller has given up
        if expected_revision is not None:
            raise ParamddsError(CAS_REFUSED, code=ErrorCode.INVALID_VALUE)
        if refused is not None:  # too many parameters: refused as the table refuses it
            return refused
        results: list[SetResult | None] = [None] * len(request)
        send: list[tuple[int, Parameter]] = []
        for i, p in enumerate(request):
            # a name paramdds refuses but the node has (ROS 2 allows more) is forwarded
            if not isinstance(p, Parameter) or not (is_valid_name(p.name) or self.has(p.name)):
                name = getattr(p, "name", "")
                results[i] = SetResult(
                    str(name), False, f"invalid parameter name {name!r}", ErrorCode.INVALID_NAME
                )
            else:
                send.append((i, self._widened(p)))
        if atomic and len(send) < len(request):
            return SetOutcome(tuple(_all_failed(request, results)), self.revision, None)
        forwarding = (
            origins.current(),
            {p.name: p.value for _, p in send if isinstance(p.value, ParameterValue)},
        )
        with self._commits:
            self._forwarding.append(forwarding)
        try:  # until its answer is committed: an event in between is this set's change
            change = self._send(send, results, atomic, deadline)
        finally:
            with self._commits:
                self._forwarding.remove(forwarding)
        done = tuple(r for r in results if r is not None)
        return SetOutcome(done, change.revision if change is not None else self.revision, change)

    def _send(
        self, send: list[tuple[int, Parameter]], results: list[SetResult | None], atomic: bool, deadline: int
    ) -> ChangeSet | None:
        """Forward ``send`` (index in the request, parameter) to the node, fill ``results``
        with its answers, and commit what it accepted."""
        try:
            answers = self.link.set([p for _, p in send], atomic, deadline) if send else []
        except Unanswered as exc:  # sent, then no answer or a failure: the node may apply it
            raise unanswered(self.link.fqn, exc) from exc
        except ParamddsError as exc:  # not sent (its service is not there)
            answers = [SetResult(p.name, False, exc.message, exc.code) for _, p in send]
        accepted: list[Parameter] = []
        for (i, p), answer in zip(send, answers, strict=True):
            results[i] = answer
            if answer.successful:
                accepted.append(p)
        if not accepted:
            return None
        with self._commits:
            return self.held.mirror({p.name: self._entry_after(p) for p in accepted})

    def _screen(self, params: object) -> tuple[list[object], SetOutcome | None]:
        """``params`` as a request list, and the outcome a table gives when the whole request
        is refused before anything runs (too many parameters; None when it is not)."""
        if isinstance(params, (str, bytes, Mapping)) or not isinstance(params, Iterable):
            raise InvalidValueError(f"a set takes a list of Parameter, got {type(params).__name__}")
        request = list(params)
        try:
            check_request_size(len(request))
        except TooLargeError as exc:
            reason = f"not applied: {exc.message}"
            results = tuple(SetResult(_name_of(p), False, reason, exc.code) for p in request)
            return request, SetOutcome(results, self.revision, None)
        return request, None

    def _entry(self, name: str) -> Entry | None:
        """The value and descriptor held for ``name`` (None when it is not declared)."""
        found = self.held.get_many([name], with_descriptors=True)[0]
        if found.value is None or found.descriptor is None:
            return None
        return found.value, found.descriptor

    def _widened(self, p: Parameter) -> Parameter:
        """paramdds widens an integer to a double; ROS 2 refuses it: type the value as every
        front end does (core.fit) before forwarding; what does not fit, the node refuses."""
        current = self._entry(p.name)
        value = p.value if isinstance(p.value, ParameterValue) else ParameterValue.from_python(p.value)
        with contextlib.suppress(ParamddsError):
            value = fit_value(p.name, value, current[1] if current is not None else None)
        return Parameter(p.name, value)

    def _entry_after(self, p: Parameter) -> Entry | None:
        """What the table holds once the node accepted ``p`` (None: deleted)."""
        value = p.value
        assert isinstance(value, ParameterValue)
        current = self._entry(p.name)
        if value.type is ParameterType.NOT_SET:
            return None
        if current is None:
            return value, ParameterDescriptor(p.name, value.type, dynamic_typing=True)
        desc = current[1]
        if desc.dynamic_typing and desc.type is not value.type:
            desc = replace(desc, type=value.type)
        return value, desc

    def mirror(self, entries: Mapping[str, Entry | None]) -> ChangeSet | None:
        """Commit ``entries`` as the node holds them (see :meth:`ParameterTable.mirror`),
        as the node's report."""
        with self._commits, origins.acting(self.reported):
            return self.held.mirror(entries)

    def _origin_of(self, name: str, entry: Entry | None) -> Origin:
        """Whose change an event's ``entry`` for ``name`` is: a forwarded set's that set it
        to this value, else the node's own."""
        for origin, values in self._forwarding:
            if name in values and entry is not None and values[name] == entry[0]:
                return origin
        return self.reported

    def apply_event(self, new: Sequence[Any], changed: Sequence[Any], deleted: Sequence[Any]) -> list[str]:
        """Commit one ``/parameter_events`` message; the names that still need a descriptor."""
        fresh: list[str] = []
        with self._commits:
            entries: dict[str, Entry | None] = {}
            for p in [*new, *changed]:
                value = value_from_ros(p.value)
                current = self._entry(p.name)
                if current is None:
                    entries[p.name] = (value, ParameterDescriptor(p.name, value.type))
                    fresh.append(p.name)
                    continue
                desc = current[1]
                if desc.dynamic_typing and desc.type is not value.type:
                    desc = replace(desc, type=value.type)
                entries[p.name] = (value, desc)
            for p in deleted:
                entries[p.name] = None
            by_origin: dict[Origin, dict[str, Entry | None]] = {}
            for name, entry in entries.items():
                by_origin.setdefault(self._origin_of(name, entry), {})[name] = entry
            for origin, some in by_origin.items():  # one revision each (one, but for a race)
                with origins.acting(origin):
                    self.held.mirror(some)
        return fresh

    def missed(self, values: Mapping[str, ParameterValue]) -> list[str]:
        """Commit the ``values`` (a read of the node) that differ from what the table holds, as
        the node's report; the names that differed."""
        with self._commits, origins.acting(self.reported):
            entries: dict[str, Entry | None] = {}
            for name, value in values.items():
                current = self._entry(name)
                if current is None or current[0] == value:
                    continue
                desc = current[1]
                if desc.dynamic_typing and desc.type is not value.type:
                    desc = replace(desc, type=value.type)
                entries[name] = (value, desc)
            self.held.mirror(entries)
        return sorted(entries)

    def resync(self, entries: Mapping[str, Entry]) -> None:
        """Make the table hold exactly ``entries`` (a fresh fetch of the node)."""
        with self._commits, origins.acting(self.reported):
            gone = {n: None for n in self.held.names() if n not in entries}
            self.held.mirror({**entries, **gone})


def forward_budget(timeout: float, deadline: int) -> float:
    """How long a forwarded set waits for the ROS 2 node: until the paramdds caller's deadline
    (by this host's clock; the caller's ``--timeout`` is honoured, whatever the link's), or
    the link's timeout for a set without a deadline (an assignment)."""
    left = deadlines.remaining(deadline)
    return timeout if left is None else max(0.0, left)


def unanswered(fqn: str, exc: ParamddsError) -> OutcomeUnknownError:
    """A forwarded set the ROS 2 node did not answer in time (or whose call failed after it was
    sent): ROS 2 has no deadline, so the node may still apply it (its /parameter_events then
    update the mirror)."""
    return OutcomeUnknownError(
        f"outcome unknown: {exc.message}; the set was forwarded to {fqn} and ROS 2 has no deadline, "
        "so it may still be applied (`get` shows it once the node has answered)"
    )


def _name_of(p: object) -> str:
    name = getattr(p, "name", "")
    return name if isinstance(name, str) else repr(name)[:80]


def _all_failed(request: Sequence[object], results: Sequence[SetResult | None]) -> list[SetResult]:
    bad = next(r for r in results if r is not None)
    return [
        r
        if r is not None
        else SetResult(
            str(getattr(p, "name", "")),
            False,
            f"not applied: the atomic set failed on {bad.name!r}",
            ErrorCode.INVALID_VALUE,
        )
        for p, r in zip(request, results, strict=True)
    ]


@dataclass
class Mirrored:
    """One ROS 2 node the bridge mirrors."""

    fqn: str
    node_id: str
    link: RosLink
    table: MirrorTable
    writers: frozenset[bytes] = frozenset()  # its /parameter_events writers, to see a restart
    evented: bool = False  # it has had a /parameter_events writer (see Mirror._unlisted)
    hosted: bool = False
    syncing: bool = False
    dirty: bool = False  # events came while a sync ran: sync again
    full: bool = False  # the next sync reads everything (not only the values: see Mirror._check)
    restarted: bool = False  # the ROS 2 node restarted while hosted: host it again once synced
    resync_at: float = 0.0  # when the next periodic resync is due (see next_resync)
    failures: int = 0
    retry_at: float = 0.0
    failing_since: float = 0.0  # when the reads of a never-read node began to fail
    unreachable: bool = False  # shown on paramdds as status=unreachable
    # the participant that found it again after it left (Mirror.found_again): it is looked
    # for, and its /parameter_events read, there
    found_on: RosSide | None = None
    stalled_since: float | None = None  # when its process stopped answering, while it does not (.liveness)
    # the rescue participants that saw it while its process did not answer: its process knew
    # them (it was stopped later, or only its executor hung), so they cannot find it again
    seen_by: set[RosSide] = field(default_factory=set)
    # hosted with what it held when it left stalled (Mirror._resume), its values not yet read
    # back from the node: checked until a read answers
    unconfirmed: bool = False
    lock: threading.Lock = field(default_factory=threading.Lock)


@dataclass(frozen=True)
class Gone:
    """A node that left the graph while its process did not answer: looked for (found_again)."""

    left: float
    since: float  # when its process stopped answering (``left`` when not known)
    seen_by: frozenset[RosSide] = frozenset()  # see Mirrored.seen_by
    writers: frozenset[bytes] = frozenset()  # its /parameter_events writers: one back is its process
    held: Mapping[str, Entry] = field(default_factory=dict)  # what it held as it left (Mirror._resume)


def next_resync(now: float, period: float) -> float:
    """When a node synced at ``now`` is next resynced: a random share of ``period`` (from
    1 - :data:`RESYNC_SPREAD` to all of it), so the nodes a bridge read together at its
    start do not all resync in the same seconds of every period."""
    return now + period * random.uniform(1.0 - RESYNC_SPREAD, 1.0)


def _seen(
    side: RosSide, fqn: str, looks: dict[int, tuple[dict[str, str], dict[str, frozenset[bytes]]]]
) -> tuple[str, frozenset[bytes]] | None:
    """``fqn``'s enclave and ``/parameter_events`` writers as ``side`` sees them (None: not
    there, or without writers); ``looks`` keeps each participant's graph for one look."""
    look = looks.get(id(side))
    if look is None:
        try:
            look = side.graph(), side.event_publishers()
        except Exception:  # closed meanwhile (the bridge is closing)
            log.debug("reading the graph of a rescue participant failed", exc_info=True)
            look = {}, {}
        looks[id(side)] = look
    graph, writers = look
    return (graph[fqn], writers[fqn]) if fqn in graph and writers.get(fqn) else None


class Mirror:
    """Every mirrored node: added, synced, resynced and removed as the ROS 2 graph changes."""

    def __init__(
        self,
        ros: RosSide,
        host: Callable[[MirrorTable], None],
        unhost: Callable[[str], None],
        forget: Callable[[str, Sequence[str]], None],
        *,
        timeout: float,
        resync: float,
        sync_threads: int = 16,
        show_unreachable: Callable[[HostedTable], None] | None = None,
        hide_unreachable: Callable[[str], None] | None = None,
    ) -> None:
        self.ros = ros
        self._host, self._unhost, self._forget = host, unhost, forget
        self._show, self._hide = show_unreachable, hide_unreachable
        self._rescues: list[tuple[RosSide, float]] = []  # new participants, the newest last
        self._rescue_lock = threading.Lock()
        self._made = 0  # rescue participants made (their names' numbers)
        self._listening: dict[int, RosSide] = {}  # id -> a rescue participant reading /parameter_events
        self._departed: dict[str, list[str]] = {}  # node id -> the names it had when it left
        self._gone: dict[str, Gone] = {}  # fqn -> how it left the graph stalled (see found_again)
        self._found: dict[str, RosSide] = {}  # fqn -> the participant that found it, at the last look
        self._unnamed: frozenset[str] = frozenset()  # the nodes back unnamed, at the last look (returning)
        self._first_seen: dict[str, float] = {}  # fqn -> when a node not mirrored yet was first seen
        self._writers_of: OrderedDict[bytes, str] = OrderedDict()  # writer GID -> fqn, of nodes that left
        self._may_return: set[bytes] = set()  # of those, the ones that may come back (see returning)
        self._lingering: set[str] = set()  # names left in the graph by nodes gone (see _unlisted)
        self._bare_since: dict[str, float] = {}  # fqn -> since when it was seen named without its writer
        self._looking_since: float | None = None  # the first look at the graph
        self._next_check = 0.0  # when the next periodic check may start (see _due_checks)
        self.timeout = timeout
        self.resync_period = resync
        self.nodes: dict[str, Mirrored] = {}  # by fqn
        self._lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=sync_threads, thread_name_prefix="paramdds-ros2-sync")
        self._closed = False
        self.lost = 0  # /parameter_events samples DDS reported lost
        self.missed = 0  # values a periodic check found different from what the events said
        self.checks: deque[tuple[float, str]] = deque(maxlen=1000)  # (when, fqn): the last checks started
        self._subscription = ros.subscribe_events(self._events_via(ros), self._on_lost)

    # -- the graph ----------------------------------------------------------------

    def update(self, wanted: Mapping[str, frozenset[bytes]], now: float) -> None:
        """Mirror exactly the nodes of ``wanted`` (fqn -> its /parameter_events writers)."""
        with self._lock:
            current = dict(self.nodes)
        for fqn in current.keys() - wanted.keys():
            if (gone := self._remove(fqn, now=now)) is not None:  # looked for (found_again)
                self._gone[fqn] = gone
        self._lingering &= wanted.keys()
        for fqn in self._unlisted(current, wanted, now):
            self._remove(fqn, UNLISTED)
            self._lingering.add(fqn)
        if self._looking_since is None:
            self._looking_since = now
        for fqn in self._first_seen.keys() - wanted.keys():
            del self._first_seen[fqn]
        for fqn, writers in wanted.items():
            if fqn in self._lingering:
                if not writers:  # the name of a node gone: not mirrored again
                    continue
                self._lingering.discard(fqn)  # a node of that name is there again
            m = current.get(fqn)
            if m is None:
                if not self._old_enough(fqn, writers, now):
                    continue
                m = self._add(fqn, writers)
                if m is None:
                    continue
                if m.unconfirmed:
                    self._resume(m, now)
                else:
                    self._submit(m)
            elif m.writers and writers - m.writers:  # a writer we did not know: the node restarted
                log.info("%s restarted: resynchronizing it under a new incarnation", fqn)
                m.writers = writers
                with m.lock:
                    m.restarted = m.hosted
                self._submit(m)
            else:
                m.writers = writers
                m.evented = m.evented or bool(writers)
                if m.failures and now >= m.retry_at:
                    self._submit(m)
                elif self._to_confirm(m, now):
                    self._submit(m, full=False)
        self._due_checks(now)

    def _resume(self, m: Mirrored, now: float) -> None:
        """Host a node back from a stall past the lease (a ``/parameter_events`` writer it had
        when it left: its process) at once, with what it held when it left, and check its values
        (one ``get_parameters``, as the periodic check does). A process stopped changed nothing
        meanwhile; what it changed as it resumed (a set queued during the stall), before this
        participant matched its writer, or while out of the bridge's view without being stopped
        (a network cut), the check commits. Read in full, a resumed process answered its first
        read 0.5-2.7 s late, while every peer rediscovered it (docs/ros2.md)."""
        log.info("%s is back from a stall: mirrored with what it held, its values checked", m.fqn)
        with m.lock:
            m.hosted = True
            m.retry_at = now + self.timeout  # the check below: not asked again meanwhile
            m.resync_at = next_resync(now, self.resync_period)
        self._host_now(m)
        self._submit(m, full=False)

    def _to_confirm(self, m: Mirrored, now: float) -> bool:
        """Whether a resumed node whose check did not answer is checked again now (not while its
        process shows stalled: the check would wait its whole timeout; see _due_checks)."""
        with m.lock:
            due = m.unconfirmed and not m.syncing and now >= m.retry_at
        return due and m.table.status is None

    def _unlisted(
        self, current: Mapping[str, Mirrored], wanted: Mapping[str, frozenset[bytes]], now: float
    ) -> list[str]:
        """The mirrored nodes still named in the graph that had a ``/parameter_events`` writer
        and have had none for :data:`UNLISTED_FOR` seconds: a node's going whose graph update
        was lost (see the module docstring). rclpy 9 makes that publisher with the node and
        destroys it only with it (the first of its endpoints), rclcpp's node holds it for its
        life; a node made without it is not judged. Its other endpoints are not asked: the
        removals of the endpoints of a process that exits at once may be lost too, in part."""
        bare = {fqn for fqn, m in current.items() if m.evented and fqn in wanted and not wanted[fqn]}
        self._bare_since = {f: self._bare_since.get(f, now) for f in bare}
        return [f for f, since in self._bare_since.items() if now - since >= UNLISTED_FOR]

    def _due_checks(self, now: float) -> None:
        """Start the periodic checks that are due, paced: one every ``resync / nodes`` seconds,
        so a round of every node spreads over the whole period (a bridge's start reads every
        node at once; without pacing their checks came in the same seconds of every period)."""
        if self.resync_period <= 0:
            return
        with self._lock:
            nodes = list(self.nodes.values())
        # not the nodes of a stalled process (.liveness): each check would hold a sync thread
        # until its timeout; they are checked once it answers again
        ready = [m for m in nodes if m.hosted and not m.failures and m.table.status is None]
        due = sorted((m for m in ready if now >= m.resync_at), key=lambda m: m.resync_at)
        gap = self.resync_period / max(1, len(nodes))
        for m in due:
            if now < self._next_check:
                return
            self._next_check = max(self._next_check, now - PACE_SLACK) + gap
            self.checks.append((now, m.fqn))
            with m.lock:
                m.resync_at = now + self.resync_period  # until the check itself says when
            self._submit(m, full=False)

    def returning(
        self, graph: Mapping[str, str], writers: Mapping[str, frozenset[bytes]]
    ) -> dict[str, frozenset[bytes]]:
        """Nodes back in the graph under no name (fqn -> their writers): the writers rmw shows
        under :data:`UNKNOWN_NODE` that a node had when it left (see the module docstring), once
        they left the graph too, or at once when its process did not answer as it left (a stall
        past the lease). A node of a process that stops cleanly leaves the graph before its
        writers, which may stay, unnamed, until the lease when the process's goodbye is lost:
        taken for the node back, it would be shown unreachable, online, with its process gone."""
        seen = {gid for gids in writers.values() for gid in gids}
        self._may_return |= self._writers_of.keys() - seen
        out: dict[str, set[bytes]] = {}
        for gid in writers.get(UNKNOWN_NODE, frozenset()):
            fqn = self._writers_of.get(gid)
            if fqn is not None and fqn not in graph and gid in self._may_return:
                out.setdefault(fqn, set()).add(gid)
        self._unnamed = frozenset(out)
        return {fqn: frozenset(gids) for fqn, gids in out.items()}

    def found_again(self, graph: Mapping[str, str], now: float) -> dict[str, tuple[str, frozenset[bytes]]]:
        """The nodes missing from ``graph`` (the bridge's participant's) that a rescue
        participant sees, fqn -> (enclave, writers): those it found before, while it still
        sees them, and those that left in the last :data:`LOOK_FOR` seconds, looked for through
        a participant their processes never knew (see the module docstring). Only a node with its
        ``/parameter_events`` writers in view counts (they name its process and its restarts)."""
        self._gone = {f: g for f, g in self._gone.items() if now - g.left <= LOOK_FOR}
        with self._lock:
            found = [m for m in self.nodes.values() if m.found_on is not None]
        looks: dict[int, tuple[dict[str, str], dict[str, frozenset[bytes]]]] = {}
        out: dict[str, tuple[str, frozenset[bytes]]] = {}
        for m in found:
            if m.fqn in graph:
                self._home(m)
            elif m.found_on is not None and (hit := _seen(m.found_on, m.fqn, looks)) is not None:
                out[m.fqn] = hit
        missing = {f: g for f, g in self._gone.items() if f not in graph}
        self._found = {}
        if not missing:
            return out
        # one their processes never knew: made after the last of them stopped answering
        newer = self._side_made_after(
            max(map(self._unknown_since, missing.values())), now, "look for nodes that left"
        )
        if newer is None:
            return out
        for fqn in missing:
            if (hit := _seen(newer, fqn, looks)) is not None:
                out[fqn] = hit
                self._found[fqn] = newer
        return out

    def looking(self) -> bool:
        """Whether a node that left the graph stalled is looked for (see :meth:`found_again`)."""
        return bool(self._gone)

    def stalls(self, stalled: Mapping[bytes, float], now: float) -> None:
        """The ROS 2 processes that do not answer now (participant -> since when, from
        :mod:`.liveness`). Each of their nodes keeps since when, and the rescue participants
        that saw it meanwhile (its process ran then, so it knew them). A process silent for
        :data:`READY_AFTER` seconds gets a rescue participant made after it stopped answering,
        if none is: should it stall past its lease, that one has the rest of the graph
        discovered when it resumes, and finds it at its first announcement (found_again)."""
        with self._lock:
            nodes = list(self.nodes.values())
        with self._rescue_lock:
            rescues = list(self._rescues)
        looks: dict[int, tuple[dict[str, str], dict[str, frozenset[bytes]]]] = {}
        for m in nodes:
            prefix = process_of(m.writers)
            since = stalled.get(prefix) if prefix is not None else None
            if since != m.stalled_since:  # a stall began, or ended
                m.stalled_since, m.seen_by = since, set()
            if since is None:
                continue
            for side, made in rescues:
                if made >= since and side not in m.seen_by and _seen(side, m.fqn, looks) is not None:
                    m.seen_by.add(side)
        silent = [t for t in stalled.values() if now - t >= READY_AFTER]
        if silent:
            self._side_made_after(max(silent), now, "be ready to find a ROS 2 process that does not answer")

    def _made_since(self, since: float) -> RosSide | None:
        """The newest rescue participant if it was made at or after ``since``."""
        with self._rescue_lock:
            newest = self._rescues[-1] if self._rescues else None
        return newest[0] if newest is not None and newest[1] >= since else None

    def _unknown_since(self, gone: Gone) -> float:
        """From when a participant made is unknown to the process of a node that left stalled:
        made after it stopped answering, unless the newest such one saw the node meanwhile
        (its process ran then: only one made after it left is sure to be new to it)."""
        with self._rescue_lock:
            newest = self._rescues[-1][0] if self._rescues else None
        return gone.left if newest in gone.seen_by else gone.since

    def _home(self, m: Mirrored) -> None:
        """A node found again that the bridge's own participant sees again: read through that
        one from now on, in full (events may have been missed meanwhile), and the rescue
        participant closed once no node uses it."""
        log.info("%s is in the bridge's ROS 2 graph again: mirrored through its participant", m.fqn)
        m.found_on = None
        m.link.renew(self.ros)
        self._submit(m)
        self._retire_rescues()

    def _side_made_after(self, since: float, now: float, why: str) -> RosSide | None:
        """A rescue participant made at or after ``since``: the newest, or a new one (at most
        one every :data:`RESCUE_EVERY` seconds, :data:`MAX_RESCUES` alive). None: none for now."""
        with self._rescue_lock:
            if self._closed:
                return None
            if self._rescues and self._rescues[-1][1] >= since:
                return self._rescues[-1][0]
            if self._rescues and now - self._rescues[-1][1] < RESCUE_EVERY:
                return None
            if len(self._rescues) >= MAX_RESCUES:
                log.debug("%d rescue participants in use: no new one to %s", len(self._rescues), why)
                return None
            self._made += 1
            try:
                side = RosSide(self.ros.domain, f"{self.ros.node.get_name()}_{self._made}", threads=2)
            except Exception:
                log.warning("cannot make a new ROS 2 participant", exc_info=True)
                return None
            log.warning("a new ROS 2 participant to %s", why)
            self._rescues.append((side, now))
            return side

    def _listen(self, side: RosSide) -> None:
        """Read ``/parameter_events`` through ``side`` too (once per participant): the events
        of the nodes mirrored through it after they left (see :meth:`_on_event`)."""
        with self._rescue_lock:
            if self._closed or id(side) in self._listening:
                return
            self._listening[id(side)] = side
        side.subscribe_events(self._events_via(side), self._on_lost)

    def by_process(self) -> dict[bytes, list[Mirrored]]:
        """The hosted mirrors by their ROS 2 process (participant; see :mod:`.liveness`)."""
        out: dict[bytes, list[Mirrored]] = {}
        with self._lock:
            nodes = list(self.nodes.values())
        for m in nodes:
            prefix = process_of(m.writers)
            if m.hosted and prefix is not None:
                out.setdefault(prefix, []).append(m)
        return out

    def knows_graph(self, now: float) -> bool:
        """Whether the ROS 2 graph seen now holds every node that was there when the bridge
        started: :data:`START_WINDOW` seconds have passed since its first look (Fast DDS finds
        a running graph that late). Until then a name missing from the graph may be taken."""
        return self._looking_since is not None and now - self._looking_since >= START_WINDOW

    def node_ids(self) -> set[str]:
        """The paramdds node ids of every node mirrored, hosted at this instant or not."""
        with self._lock:
            return {m.node_id for m in self.nodes.values()}

    def _old_enough(self, fqn: str, writers: frozenset[bytes], now: float) -> bool:
        """Whether a node not mirrored yet has been in the graph for :data:`MIN_AGE` seconds, so
        that a tool's node (``ros2 param`` lives well under a second) is never mirrored. The
        nodes of the bridge's first :data:`START_WINDOW` seconds of looking were there before
        it, and a node back with a writer it had when it left is the same process: both are
        mirrored at once."""
        assert self._looking_since is not None
        seen = self._first_seen.setdefault(fqn, now)
        back = any(self._writers_of.get(gid) == fqn for gid in writers)
        if back or seen - self._looking_since < START_WINDOW or now - seen >= MIN_AGE:
            self._first_seen.pop(fqn, None)
            return True
        return False

    def _add(self, fqn: str, writers: frozenset[bytes]) -> Mirrored | None:
        try:
            node_id = canonical_node_id(fqn)
        except ParamddsError as exc:
            log.warning("cannot mirror the ROS 2 node %s: %s", fqn, exc)
            return None
        gone = self._gone.pop(fqn, None)
        # found by a participant its process never knew, or back unnamed (see returning) while
        # one exists: the bridge's participant may see only part of the resumed process
        found_on = self._found.pop(fqn, None)
        if found_on is None and gone is not None and fqn in self._unnamed:
            found_on = self._made_since(self._unknown_since(gone))
        if found_on is not None:
            log.warning("%s is back: mirrored through a participant its process did not know", fqn)
            self._listen(found_on)
        link = RosLink(found_on or self.ros, fqn, self.timeout)
        m = Mirrored(
            fqn, node_id, link, MirrorTable(node_id, link), writers, evented=bool(writers), found_on=found_on
        )
        if gone is not None and writers & gone.writers:  # its process, back from its stall
            m.table.resync(gone.held)
            m.unconfirmed = True
        with self._lock:
            self.nodes[fqn] = m
        return m

    def _remove(self, fqn: str, why: str = "left the ROS 2 graph", now: float = 0.0) -> Gone | None:
        """Stop mirroring ``fqn`` (it left at ``now``); how it left if it may come back: it was
        hosted (it went offline on paramdds) and its process did not answer as it left (a
        stall past the lease, or a crash; a clean stop answers to the end)."""
        with self._lock:
            m = self.nodes.pop(fqn, None)
        if m is None:
            return None
        stalled = m.table.status is not None  # its process did not answer when it left (.liveness)
        for gid in m.writers:  # its process may come back (a stall past the lease): see returning
            self._writers_of[gid] = fqn
            self._writers_of.move_to_end(gid)
            if stalled:
                self._may_return.add(gid)
            else:
                self._may_return.discard(gid)
        while len(self._writers_of) > REMEMBERED:
            self._may_return.discard(self._writers_of.popitem(last=False)[0])
        with m.lock:
            hosted, m.hosted = m.hosted, False
            shown, m.unreachable = m.unreachable, False
        if hosted:
            log.info("%s %s: offline", fqn, why)
            self._departed[m.node_id] = m.table.names()
            self._unhost(m.node_id)
        if shown and self._hide is not None:
            self._hide(m.node_id)
        m.link.close()
        self._retire_rescues()
        if not (hosted and stalled):
            return None
        since = now if m.stalled_since is None else min(m.stalled_since, now)
        held = {name: (value, desc) for name, value, desc in m.table.snapshot()}
        return Gone(now, since, frozenset(m.seen_by), m.writers, held)

    def _submit(self, m: Mirrored, *, full: bool = True) -> None:
        """Read ``m`` on the sync pool: everything (``full``), or only check its values."""
        with m.lock:
            m.full = m.full or full
            if m.syncing:
                m.dirty = True
                return
            m.syncing = True
        if not self._closed:
            self._pool.submit(self._sync, m).add_done_callback(lambda f: self._failed_sync(m, f))

    def _failed_sync(self, m: Mirrored, done: Future[None]) -> None:
        """Log a sync that raised (the pool keeps what it raises to itself: the node was left
        unread, or unhosted, with nothing said), and let the node be read again."""
        exc = None if done.cancelled() else done.exception()
        if exc is None:
            return
        with self._lock:
            gone = self.nodes.get(m.fqn) is not m  # it left meanwhile: its clients were closed under it
        log.log(
            logging.DEBUG if gone else logging.ERROR,
            "reading %s failed: %s: %s",
            m.fqn,
            type(exc).__name__,
            exc,
            exc_info=exc,
        )
        with m.lock:
            m.syncing = False

    def _sync(self, m: Mirrored) -> None:
        import time

        while True:
            with m.lock:
                m.dirty = False
                full, m.full = m.full or not m.hosted, False
            if not full:
                if self._check(m):
                    return
                continue
            try:
                entries = m.link.fetch()
            except ParamddsError as exc:
                self._failed(m, exc)
                return
            with m.lock:
                # a node that restarted in ROS 2 is hosted again (a new incarnation, as a
                # restarted server's), as if it had left and come back: unhosted here,
                # resynchronized, hosted below and what it no longer has deleted
                renew, m.restarted = m.hosted and m.restarted, False
                m.hosted = m.hosted and not renew
            if renew:
                self._departed[m.node_id] = m.table.names()
                self._unhost(m.node_id)
                # a new table: its revisions start again, as a restarted server's node's do
                m.table = MirrorTable(m.node_id, m.link)
            m.table.resync(entries)
            with self._lock:
                still = self.nodes.get(m.fqn) is m
            with m.lock:
                host = still and not m.hosted
                m.hosted = m.hosted or host
                m.failures = 0
                m.failing_since = 0.0
                m.unconfirmed = False
                shown, m.unreachable = m.unreachable, False
                m.resync_at = next_resync(time.monotonic(), self.resync_period)
            if shown:
                log.warning("%s answers now: mirrored", m.fqn)
                if self._hide is not None:
                    self._hide(m.node_id)
            with m.lock:
                again = m.dirty
                if not again:
                    m.syncing = False
            if host:
                self._host_now(m)
            if not again:
                return

    def _host_now(self, m: Mirrored) -> None:
        self._host(m.table)
        # readers still hold what it had last time: what it no longer has is deleted
        self._forget(m.node_id, self._departed.pop(m.node_id, []))

    def _check(self, m: Mirrored) -> bool:
        """The periodic check of a hosted node: one ``get_parameters`` of every name it holds
        (``/parameter_events`` carries every change; what it may have missed is a value, such
        as a ROS 2 set racing a forwarded one). What differs is committed; a name the node no
        longer has means a full read. True when done; False to go round the sync loop again
        (events came meanwhile, or a full read is needed)."""
        import time

        names = m.table.names()
        try:
            values = m.link.values(names) if names else []
        except ParamddsError as exc:  # a stalled or busy node: checked again next period
            log.debug("checking %s failed: %s", m.fqn, exc.message)
            values = None
        if values is not None and any(v.type is ParameterType.NOT_SET for v in values):
            with m.lock:
                m.full = True
            return False
        if values is not None:
            missed = m.table.missed(dict(zip(names, values, strict=True)))
            if missed:
                self.missed += len(missed)
                log.info("%s: %s differed from its events; mirrored now", m.fqn, ", ".join(missed))
        now = time.monotonic()
        with m.lock:
            m.resync_at = next_resync(now, self.resync_period)
            m.unconfirmed = m.unconfirmed and values is None
            m.retry_at = now + RETRY if m.unconfirmed else m.retry_at
            again = m.dirty or m.full
            if not again:
                m.syncing = False
        return not again

    def _failed(self, m: Mirrored, exc: ParamddsError) -> None:
        """A read of ``m`` failed: when to try again, and with what (see the module doc)."""
        import time

        now = time.monotonic()
        with m.lock:
            m.syncing = False
            m.failures += 1
            failures = m.failures
            fresh = not m.hosted  # never read (or left and came back): its services never answered
            m.failing_since = m.failing_since or now
            show = fresh and not m.unreachable and now - m.failing_since >= UNREACHABLE_AFTER
            m.unreachable = m.unreachable or show
            if fresh and failures <= FAST_TRIES:
                m.retry_at = now + RETRY
            else:
                m.retry_at = now + min(30.0, 1.0 * 2 ** min(failures, 5))
        if fresh and failures >= 2:
            # clients whose service never matched: new ones (new endpoints, discovered afresh),
            # from RESCUE_AT on in a new participant, which discovers the whole graph afresh
            m.link.renew(self._rescue_side(m) if failures >= RESCUE_AT else None)
        log.log(
            logging.WARNING if failures == 3 or show else logging.DEBUG,
            "cannot read the parameters of %s (%s); retrying%s",
            m.fqn,
            exc.message,
            ": shown unreachable on paramdds" if show else "",
        )
        if show and self._show is not None:
            self._show(UnreachableTable(m.node_id, m.fqn))
            with self._lock:
                gone = self.nodes.get(m.fqn) is not m
            with m.lock:
                hide, m.unreachable = gone and m.unreachable, m.unreachable and not gone
            if hide and self._hide is not None:  # it left the graph meanwhile
                self._hide(m.node_id)

    def _rescue_side(self, m: Mirrored) -> RosSide | None:
        """A participant made after ``m`` began to fail (it discovers the graph afresh, knowing
        the parameter service types first): see :meth:`_side_made_after`. None: keep the
        current one for now."""
        import time

        why = f"reach {m.fqn}, whose services do not answer"
        side = self._side_made_after(m.failing_since, time.monotonic(), why)
        return None if side is m.link.ros else side

    def _retire_rescues(self) -> None:
        """Close the rescue participants no longer the newest that no node's clients use."""
        with self._lock:
            used = {id(s) for m in self.nodes.values() for s in (m.link.ros, m.found_on)}
        with self._rescue_lock:
            idle = [(s, t) for s, t in self._rescues[:-1] if id(s) not in used]
            self._rescues = [r for r in self._rescues if r not in idle]
            for side, _ in idle:
                self._listening.pop(id(side), None)
        for side, _ in idle:
            side.close()

    # -- /parameter_events --------------------------------------------------------

    def _events_via(self, side: RosSide) -> Callable[[Any], None]:
        """The ``/parameter_events`` callback of the subscription made through ``side``."""
        return lambda msg: self._on_event(msg, side)

    def _on_event(self, msg: Any, via: RosSide) -> None:
        """One ``/parameter_events`` message, read through ``via``: taken for a node found again
        only from the participant that found it, for any other only from the bridge's own (a
        node seen by two would have its events applied twice, out of order)."""
        with self._lock:
            m = self.nodes.get(msg.node)
        if m is None or (m.found_on or self.ros) is not via:
            return
        with m.lock:
            if m.syncing:
                m.dirty = True  # a sync is reading the node: read it again after
        fresh = m.table.apply_event(msg.new_parameters, msg.changed_parameters, msg.deleted_parameters)
        if fresh and not self._closed:
            self._pool.submit(self._describe, m, fresh)

    def _describe(self, m: Mirrored, names: list[str]) -> None:
        """Descriptors of parameters an event declared (events carry values only)."""
        try:
            entries = m.link.entries(names)
        except ParamddsError as exc:
            log.debug("describing %s on %s failed: %s", names, m.fqn, exc.message)
            self._submit(m)
            return
        m.table.mirror({n: e for n, e in entries.items() if m.table.has(n)})

    def _on_lost(self) -> None:
        """DDS lost /parameter_events samples: every mirrored node may be stale."""
        self.lost += 1
        log.warning("/parameter_events samples were lost: resynchronizing every mirrored node")
        with self._lock:
            nodes = list(self.nodes.values())
        for m in nodes:
            self._submit(m)

    def close(self) -> None:
        self._closed = True
        self._pool.shutdown(wait=False, cancel_futures=True)
        for fqn in list(self.nodes):
            self._remove(fqn)
        with self._rescue_lock:
            rescues, self._rescues = self._rescues, []
            self._listening.clear()
        for side, _ in rescues:
            side.close()
