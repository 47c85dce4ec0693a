"""The parameter server: hosts one or many node ids behind seven global topics.

How it works:

* Each request topic is read by one content-filtered reader (:mod:`.filters`): a
  native C filter on the node ids hosted here, updated by ``add_node`` and
  ``remove_node``, so Cyclone drops other nodes' requests before Python sees
  them. (A *Python* filter would deadlock: it runs on Cyclone's receive thread
  under the reader's lock and waits for the GIL, which ``take`` holds while it
  waits for that lock.) The handlers still ignore requests for node ids not
  hosted here: that is the whole filter where the extension is not built. The
  assignment reader is not filtered: it keeps assignments for nodes added later.
* **One dispatch thread** takes the samples and hands each request to its node's
  worker. It runs no user code, so nothing a node does can stall it; it asserts
  the state writer's MANUAL_BY_TOPIC liveliness on every tick, so if the loop
  stops or stalls every node of the process goes offline within the lease.
* **One worker per hosted node** (a thread, started on first use) is that node's
  one commit path, used by every source of change: a DDS request, a retained
  assignment, and the application's own ``table.set``/``declare``/``undeclare``
  (a change listener queues those). For each it runs, in this order: validate
  and commit (the table, with its callbacks), persist (the ``persisters``, e.g.
  ``--persist``'s journal), reply, publish. A slow callback or fsync of one node
  never delays another. A get or list is answered on the dispatch thread when the
  node's worker is idle and its table's lock free (never waiting), else queued
  behind the node's sets. A worker busy with one job for longer than the lease is
  reported stalled: logged, and its presence unregistered (monitors show it
  offline) until the job returns. A table whose sets wait on another process
  (``forwards_writes``: a mirrored ROS 2 node) has its reads answered at once even
  while a set is out, and shows ``status=stale`` instead of offline.
* Parameter state goes to ``ParameterEvents`` keyed by (node_id, name): declare and
  change write, delete disposes, a graceful stop unregisters (the State profile
  turns autodispose off, so readers see "no writers", not "deleted"). Each node
  also keeps a presence instance (name ``""``) with host, pid, revision and count.
* Retained assignments arrive on ``SetParametersRequest`` with ``retained=True``
  from a TRANSIENT_LOCAL writer; a second, TRANSIENT_LOCAL reader takes them. Those
  for nodes not hosted yet are kept (the newest per node, bounded) and applied
  when such a node is added, also after ``start()``.
* **Incarnation.** Each time a server starts hosting a node it draws a random non-zero
  64-bit incarnation, written with every state, presence and reply sample of that node.
  A revision alone repeats across restarts (a node restored from ``--persist`` is back
  at r9 after a restart from r13, and a fresh one counts from its declarations again);
  (incarnation, revision) never does. Compare-and-set compares both when the request
  names an incarnation (``expected_incarnation`` != 0), the revision alone otherwise
  (a peer that knows no incarnation). The check lives here, not in the core table: an
  incarnation belongs to the hosting, not to the parameters.
* Retried requests (same client_id, request_id and bytes as received) get the cached
  reply again and are never applied twice. The same ids with other content are a
  new request: a client restarted with a fixed client_id counts from 1 again.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterable, Sequence
from functools import partial
from typing import Any

from cyclonedds.core import InstanceState, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Qos
from cyclonedds.sub import DataReader
from cyclonedds.util import duration

from ..core import deadline as deadlines
from ..core import origin as origins
from ..core.history import NodeHistory, Retention
from ..core.hosted import HostedTable
from ..core.limits import check_request_size
from ..core.names import canonical_node_id
from ..core.results import SetResult
from ..core.revision import incarnation_text
from ..core.values import Parameter, ParameterType, ParameterValue
from ..errors import ErrorCode, ParamddsError
from ._binding import BatchingWriter, flush_writes
from .dispatch import SERIALIZED, Dispatcher
from .filters import STALE, NativeFilter, filter_tag, filtered_topic, gone_tag, status_tag
from .node_worker import NodeWorker, Staged
from .participant import poll_peers
from .publication import Persistence, StatePublication
from .qos import QosProfiles
from .topics import make_topic
from .transport import transport_of
from .wire import types as wire
from .wire.cdr import encode
from .wire.convert import descriptor_to_wire, parameter_from_wire, value_from_wire, value_to_wire
from .wire.history import last_change_to_wire, query_from_wire, record_to_wire
from .wire.state import StateKey, StateSample, decode_key, decode_state

log = logging.getLogger(__name__)

DEDUP_WINDOW = 4096  # replies kept for retried requests, per server
DEDUP_BYTES = 16 * 1024 * 1024  # and at most this many bytes of request content
RETAINED_NODES = 1024  # nodes not hosted (yet) whose retained assignments are kept
REFUSALS_KEPT = 16  # refused parameters of one request kept in its node's history, at most
LEASE = 1.0  # seconds: the state writer's liveliness lease, asserted from the dispatch loop


class ParameterServer:
    """Serves the tables it hosts. ``start()`` begins serving, ``close()`` stops gracefully."""

    def __init__(
        self,
        participant: DomainParticipant,
        qos: QosProfiles | None = None,
        *,
        nodes: Iterable[str] | None = None,
        tags: Sequence[str] = (),
        retention: Retention | None = None,
    ) -> None:
        """``nodes``: the node ids this server will host; needed in secure mode only, where
        its writers are created in those nodes' partitions (see :mod:`.transport`).
        ``tags``: more ``name=value`` items for its presence value (``origin=ros2``).
        ``retention``: how much history each node keeps (:class:`~paramdds.core.history.Retention`)."""
        self._dp = participant
        self._retention = retention or Retention()
        self._histories: dict[str, NodeHistory] = {}
        # request sample -> the identity DDS Security authenticated for its writer, or None
        # (then the request's ``who`` is recorded as a claim, unverified)
        self.authenticate: Callable[[Any], str | None] | None = None
        self._qos = qos or QosProfiles.load()
        self._tables: dict[str, HostedTable] = {}
        self._workers: dict[str, NodeWorker] = {}
        self._replies_lock = threading.Lock()
        # (node, client_id, request_id) -> (encoded request, reply), for retried requests
        self._replies: OrderedDict[tuple[str, int, int], tuple[bytes, Any]] = OrderedDict()
        self._replies_bytes = 0
        self._retained: OrderedDict[str, list[Any]] = OrderedDict()  # node -> assignments
        self._hosting = threading.Lock()  # guards _workers/_tables/_retained changes
        self._logged_bad: set[str] = set()
        self.persistence = Persistence()
        self.persisters = self.persistence.persisters  # the hooks: append a Persister
        self._started = False
        self._closed = False
        self._filter = NativeFilter("nodes")  # the request readers' filter: the nodes hosted here
        # other processes' claims of any node (secure: presence in our partitions), and nothing else
        self._twins = NativeFilter("presence")
        # what the presence value says about this server (a string array of name=value tags):
        # how it filters, and the caller's (``origin=ros2`` for the ROS 2 bridge's mirrors)
        tags = [filter_tag(self._filter.native), *tags]
        presence_tags = wire.ParameterValue(type=int(ParameterType.STRING_ARRAY), string_array_value=tags)
        self._twins.set_nodes(None)
        self._twins_seen: set[tuple[str, str, int]] = set()
        # node -> (host, pid) of another live process claiming it: a node hosted here then
        # has a twin, also one added after the claim arrived
        self._claimed: dict[str, tuple[str, int]] = {}
        self.foreign_requests = 0  # requests that reached a handler for a node not hosted here
        self._last_tick = time.monotonic()
        self._again_at: float | None = None  # when presence is written once more after a late loop

        # secure mode: writers and readers in the partitions of the nodes hosted here
        self._transport = transport_of(participant)
        self._where = self._transport.hosting(nodes)
        self._pub = self._where.publisher
        self._sub = self._where.subscriber
        state_qos = self._qos.writer("ParameterEvents")
        # liveliness is asserted by our dispatch loop, not by Cyclone's threads (see above)
        state_qos += _manual_liveliness()
        with self._transport.refused(f"serving nodes {sorted(self._where.nodes or ())}"):
            state_writer = BatchingWriter(
                self._pub, make_topic(participant, "ParameterEvents", wire.ParameterEvent), state_qos
            )
            claims = None
            if self._where.claim_publisher is not None:  # AUTOMATIC lease: a claim goes with its process
                claims = DataWriter(
                    self._where.claim_publisher,
                    make_topic(participant, "ParameterEvents", wire.ParameterEvent),
                    self._qos.writer("ParameterEvents"),
                )
            self.publication = StatePublication(
                state_writer, presence_tags, self._tables.__contains__, claims
            )
            replies = ("SetParametersResponse", "GetParametersResponse", "ListParametersResponse")
            self._reply_writers = {
                name: (BatchingWriter if name == "SetParametersResponse" else DataWriter)(
                    self._pub, make_topic(self._dp, name, wire.TOPICS[name]), self._qos.writer(name)
                )
                for name in replies
            }
            # the answers to assignments: kept for an assigner whose reader matches after the answer
            self._answers = DataWriter(
                self._pub, make_topic(self._dp, "SetParametersResponse", wire.SetParametersResponse),
                self._qos.answer_writer(),
            )
        self._dispatcher = Dispatcher(participant, "paramdds-server", tick=self._tick, period=LEASE / 4)

    def _request_topic(self, name: str) -> Any:
        return filtered_topic(self._dp, name, wire.TOPICS[name], self._filter)

    @property
    def filter(self) -> NativeFilter:
        """The request readers' filter (``filter.native`` is False where the extension is missing)."""
        return self._filter

    # -- hosting -----------------------------------------------------------------

    def add_node(self, table: HostedTable) -> None:
        """Host ``table``: publish its state and presence and serve its requests."""
        node_id = table.node_id
        self._where.admit(node_id)
        if node_id in self._tables:
            raise ParamddsError(f"node {node_id!r} is already hosted by this server")
        history = self.history(node_id)
        start = origins.local_origin(origins.Via.START)
        history.started(((n, v) for n, v, _ in table.snapshot()), table.revision, start, time.time_ns())
        worker = NodeWorker(
            self.persistence, self.publication, table, replied=self._send_set_replies, history=history
        )
        self.publication.begin(table, history.last_changes())
        with self._hosting:  # against _on_assignment: no assignment falls between the two
            self._workers[node_id] = worker
            self._tables[node_id] = table
            self._refilter()
            retained = self._retained.pop(node_id, [])
        other = self._claimed.get(node_id)
        if other is not None:  # a twin that claimed the node before it was hosted here
            self._warn_twin(node_id, *other)
        for request in retained:  # assignments that arrived before this node was hosted
            worker.submit_commit(partial(self._handle_set, worker, request, reply=False))

    def remove_node(self, node_id: str) -> None:
        """Stop hosting ``node_id`` gracefully: its instances become "no writers", not deleted."""
        with self._hosting:
            table = self._tables.pop(node_id)
            worker = self._workers.pop(node_id)
            self._refilter()
        worker.close(timeout=2.0)
        self.publication.end(node_id, table.names())

    def forget(self, node_id: str, names: Sequence[str]) -> None:
        """Dispose the state of ``names``, which hosted ``node_id`` no longer has: for a node
        hosted again with fewer parameters than readers remember from its last time (its
        old instances were unregistered, so readers still hold them)."""
        if node_id not in self._tables:
            return
        for name in names:
            if name and not self._tables[node_id].has(name):
                self.publication.dispose(node_id, name)

    @property
    def nodes(self) -> dict[str, HostedTable]:
        return dict(self._tables)

    def history(self, node_id: str) -> NodeHistory:
        """The history of ``node_id`` (made on first use: a store restores into it before
        the node is added)."""
        with self._hosting:
            history = self._histories.get(node_id)
            if history is None:
                history = self._histories[node_id] = NodeHistory(node_id, self._retention)
            return history

    def incarnation(self, node_id: str) -> int:
        """The incarnation of a node hosted here (0 for one that is not)."""
        return self.publication.incarnation(node_id)

    def _refilter(self) -> None:
        """The filters accept the nodes hosted now; before :meth:`start` nothing is served,
        and the node ids go in once there (each update copies every id: hosting 10,000
        nodes one ``add_node`` at a time would be quadratic). Call under ``_hosting``."""
        if self._started:
            self._filter.set_nodes(self._tables)

    def start(self) -> ParameterServer:
        """Serve. Retained assignments are applied from here on, also to nodes added later."""
        with self._hosting:
            self._started = True
            self._refilter()
        # the request readers, made once the filter holds the nodes hosted: a client sends a copy
        # of a waiting request as soon as a new reader matches, and one that matched before would
        # have dropped it (nothing hosted yet), with nothing left to match
        handlers = {
            "SetParametersRequest": self._on_set,
            "GetParametersRequest": self._on_get,
            "ListParametersRequest": self._on_list,
        }
        for name, handler in handlers.items():
            topic = self._request_topic(name)
            reader = self._transport.reader(topic, self._qos.reader(name), self._where.nodes)
            self._dispatcher.add(reader, self._transport.guard(reader, handler))
        # not filtered: assignments for nodes not hosted yet are kept for when they are added
        requests = make_topic(self._dp, "SetParametersRequest", wire.SetParametersRequest)
        reader = DataReader(self._sub, requests, self._qos.assignment_reader())
        self._dispatcher.add(reader, self._transport.guard(reader, self._on_assignment))
        # other processes' claims (few: one per node; secure: presence alone passes the filter)
        if self._twins.native:
            twins = filtered_topic(self._dp, "ParameterEvents", wire.ParameterEvent, self._twins)
        else:
            twins = make_topic(self._dp, "ParameterEvents", wire.ParameterEvent)
        reader = DataReader(self._where.claim_subscriber, twins, self._twin_qos())
        self._dispatcher.add_raw(reader, _decode_presence, self._transport.guard_raw(reader, self._on_twins))
        self._last_tick = time.monotonic()
        self._dispatcher.start()
        return self

    def _twin_qos(self) -> Qos:
        # every other process's claims (a twin's among them), not our own process's: they are
        # many (hosting) and never a twin
        qos: Qos = self._qos.reader("ParameterEvents") + Qos(
            Policy.History.KeepLast(4), Policy.IgnoreLocal.Process
        )
        return qos

    def _on_twins(self, samples: Sequence[tuple[Any, Any]]) -> None:
        """Other processes' claims: one of a node hosted here is a twin, warned about once per
        process. When that process stops (or dies), its claim loses its writer here: write
        our presence again, saying which one went (a ``gone=`` tag), so monitors that showed
        its host and pid, or listed it as a second host, show this process alone. Only
        presence instances count (secure mode reads a twin's parameters too)."""
        for sample, info in samples:
            if sample.name:
                continue
            node = sample.node_id
            if isinstance(sample, StateKey):
                if info.instance_state == InstanceState.Alive:
                    continue
                other = self._claimed.pop(node, None)
                worker = self._workers.get(node)
                if other is not None and worker is not None:
                    self._presence_again(worker, gone_tag(*other))
            elif (sample.host, sample.pid) != (self.publication.host, self.publication.pid):
                self._claimed[node] = (sample.host, sample.pid)
                if node in self._workers:
                    self._warn_twin(node, sample.host, sample.pid)

    def _warn_twin(self, node: str, host: str, pid: int) -> None:
        if (host, pid) == (self.publication.host, self.publication.pid) or (
            node,
            host,
            pid,
        ) in self._twins_seen:
            return
        self._twins_seen.add((node, host, pid))
        log.warning(
            "node %r is also hosted by pid %d on %s: two processes serve one node id and "
            "requests reach both; stop one of them",
            node,
            pid,
            host,
        )

    def close(self) -> None:
        """Graceful stop: unregister every instance (readers see the nodes offline)."""
        if self._closed:
            return
        self._closed = True
        self._dispatcher.close()
        for node_id in list(self._tables):
            self.remove_node(node_id)

    def __enter__(self) -> ParameterServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- liveliness ----------------------------------------------------------------

    def _tick(self) -> None:
        """From the dispatch loop: we are alive; a node whose worker is stuck is not."""
        self.publication.assert_alive()
        now = time.monotonic()
        late, self._last_tick = now - self._last_tick, now
        # a gap near the lease may already have let a monitor's lease run out (it starts on
        # receipt, its check runs on its own clock): write presence again with a margin
        if late > 0.75 * LEASE:
            self._present_again(late)
            self._again_at = now + LEASE
        elif self._again_at is not None and now >= self._again_at:
            # once more, a lease later: a reader whose lease for our writer ran out only after the
            # first rewrite reached it (a starved reader handles its lease and our samples in
            # any order) would keep those nodes offline until their next change (seen: 72 of a
            # bridge's 100 mirrors offline for good after its process starved for 2.4 s)
            self._again_at = None
            self._present_all()
        poll_peers(self._dp)
        for worker in list(self._workers.values()):
            if worker.check_stall(now, LEASE):
                node = worker.table.node_id
                if worker.table.forwards_writes:  # waiting on the node's own process: values kept
                    log.warning(
                        "node %r: a set has waited on its process for over %.1f s; it shows stale "
                        "(reads answered from the last known values) until the set returns",
                        node,
                        LEASE,
                    )
                    self.publication.write_presence(worker.table, status_tag(STALE))
                    continue
                log.warning(
                    "node %r stalled: one job (a callback or a persistence write) has run for over "
                    "%.1f s; it shows offline until the job returns",
                    node,
                    LEASE,
                )
                self.publication.offline(node)

    def _present_again(self, late: float) -> None:
        """After the whole loop stalled near or past the lease: write every node's presence again.

        The process was stopped (SIGSTOP, a debugger) or starved, so its liveliness
        lapsed and every monitor marked its nodes offline. Asserting liveliness again
        does not bring an instance back: Cyclone keeps it not-alive until the writer
        writes it, so without this a node that recovered would look offline until its
        next change. A node whose worker is busy writes its presence when the job ends. The
        tick writes it once more a lease later (see there).
        """
        log.warning("the server did not run for %.1f s (stopped or starved): writing presence again", late)
        self._present_all()

    def _present_all(self) -> None:
        for worker in list(self._workers.values()):
            self._presence_again(worker)

    def _presence_again(self, worker: NodeWorker, *tags: str) -> None:
        """Write a node's presence again: now when its worker is idle, else after its jobs."""
        if worker.idle():
            self.publication.write_presence(worker.table, *tags)
        else:
            worker.submit(partial(self.publication.write_presence, worker.table, *tags))

    # -- requests -------------------------------------------------------------------

    def _worker_for(self, node_id: str) -> NodeWorker | None:
        worker = self._workers.get(node_id)
        if worker is None:
            try:
                worker = self._workers.get(canonical_node_id(node_id))
            except ParamddsError:
                return None
        return worker

    def _on_set(self, samples: Sequence[Any]) -> None:
        for request in samples:
            # assignments (retained) are taken by the assignment reader
            if request.sample_info.valid_data and not request.retained:
                worker = self._worker_for(request.node_id)
                if worker is None:
                    self.foreign_requests += 1
                else:
                    worker.submit_commit(partial(self._handle_set, worker, request, reply=True))

    def _on_assignment(self, samples: Sequence[Any]) -> None:
        for request in samples:
            if not (request.sample_info.valid_data and request.retained):
                continue
            with self._hosting:
                worker = self._worker_for(request.node_id)
                if worker is None:
                    self._keep_retained(request)
            if worker is not None:
                worker.submit_commit(partial(self._handle_set, worker, request, reply=False))

    def _keep_retained(self, request: Any) -> None:
        """Keep an assignment for a node not hosted (yet): applied if it is added later."""
        try:
            node = canonical_node_id(request.node_id)
        except ParamddsError:
            return
        kept = self._retained.setdefault(node, [])
        kept.append(request)
        del kept[:-16]  # the newest few per node
        self._retained.move_to_end(node)
        while len(self._retained) > RETAINED_NODES:
            self._retained.popitem(last=False)

    def _handle_set(self, worker: NodeWorker, request: Any, *, reply: bool) -> Staged:
        """Validate and commit one request, on the node's worker; the :class:`Staged` it returns
        replies once the worker has persisted its changes (with those of the requests committed
        beside it: one flush), then the worker publishes them."""
        table = worker.table
        key = (table.node_id, request.client_id, request.request_id)
        content = b""
        if reply:
            content = _content(request)
            with self._replies_lock:
                seen = self._replies.get(key)
            # a retry carries the same bytes; the same ids with other content are a new
            # request (a client restarted with a fixed client_id counts from 1 again)
            if seen is not None and seen[0] == content:
                # after the group's flush: the original may be in this very group
                return Staged((), partial(self._resend, seen[1]))
        response = wire.SetParametersResponse(
            node_id=table.node_id,
            client_id=request.client_id,
            request_id=request.request_id,
            incarnation=self.incarnation(table.node_id),
        )
        origin = self._origin_of(request, reply)
        try:
            with origins.acting(origin):
                response.results, response.revision = self._apply_set(table, request)
        except ParamddsError as exc:
            response.code, response.reason, response.revision = exc.code.value, exc.message, table.revision
        except Exception as exc:  # never let a bad request take the server down
            log.exception("set request on %s failed", table.node_id)
            response.code, response.reason = ErrorCode.INTERNAL.value, f"internal error: {exc}"
            response.revision = table.revision
        self._record_refusals(worker, origin, request, response)
        changes = worker.take_pending()
        if reply:  # known at once, so a retry committed in the same group is not applied again
            self._remember(key, content, response)
        return Staged(changes, partial(self._finish_set, table, response, changes, reply))

    def _origin_of(self, request: Any, interactive: bool) -> origins.Origin:
        """Who asks, verified when DDS Security authenticated the request's writer."""
        default = origins.Via.API if interactive else origins.Via.ASSIGN
        via = origins.parse_via(request.via) or request.via or default.value
        subject = None
        if self.authenticate is not None:
            try:
                subject = self.authenticate(request)
            except Exception:
                log.exception("could not authenticate a request's writer")
        if subject:
            return origins.Origin(subject, via, verified=True)
        return origins.Origin(request.who or f"client {request.client_id:016x}", via)

    def _record_refusals(
        self, worker: NodeWorker, origin: origins.Origin, request: Any, response: Any
    ) -> None:
        """Keep the writes the node refused in its history: what was asked, what is, why
        (the first REFUSALS_KEPT of a request: a flood of bad requests cannot push the
        node's changes out of a history bounded by count any faster than that)."""
        if response.code:
            refused = [(p.name, response.code, response.reason) for p in request.parameters]
        else:
            refused = [(r.name, r.code, r.reason) for r in response.results if not r.successful]
        del refused[REFUSALS_KEPT:]
        if not refused:
            return
        asked = {p.name: p.value for p in request.parameters}
        table = worker.table
        names = [n for n, _, _ in refused]
        now = {r.name: r.value for r in table.get_many(names) if r.value is not None}
        records = [(n, now.get(n), _value_or_none(asked.get(n)), code, why) for n, code, why in refused]
        worker.history.refused(origin, table.revision, records)

    def _resend(self, response: Any, _failure: str) -> None:
        self._send_reply("SetParametersResponse", response)

    def _finish_set(
        self, table: HostedTable, response: Any, changes: Sequence[Any], reply: bool, failure: str
    ) -> None:
        """A set's second half, once its changes are persisted (``failure`` says what failed)."""
        if failure:
            response.results = [_not_persisted(r, changes[-1].revision, failure) for r in response.results]
        if reply:
            self._send_reply("SetParametersResponse", response)
            return
        if not all(r.successful for r in response.results) or response.code:
            log.warning("assignment for %s partly refused: %s", table.node_id, _summary(response))
        # an assignment is answered too: its assigner reports each refusal (paramdds.dds.assign)
        try:
            self._answers.write(response)
        except Exception as exc:
            self._log_once("write:answers", "could not answer an assignment of %s: %s", table.node_id, exc)

    def _apply_set(self, table: HostedTable, request: Any) -> tuple[list[Any], int]:
        deadlines.check(request.deadline)  # after its wait in the worker's queue (again at the commit)
        check_request_size(len(request.parameters))
        params: list[Parameter | None] = []
        bad: dict[int, SetResult] = {}
        for i, p in enumerate(request.parameters):
            try:
                params.append(parameter_from_wire(p))
            except ParamddsError as exc:
                params.append(None)
                bad[i] = SetResult(p.name, False, exc.message, exc.code)
                who = request.client_id
                self._log_once("malformed-value", "bad value for %r from client %x: %s", p.name, who, exc)
        expected = None if request.expected_revision < 0 else int(request.expected_revision)
        incarnation = self.incarnation(table.node_id)
        if request.expected_incarnation and request.expected_incarnation != incarnation:
            reason = (
                f"not applied: node {table.node_id!r} is at revision {table.revision} of incarnation "
                f"{incarnation_text(incarnation)} (restarted since), not the expected revision "
                f"{request.expected_revision} of incarnation {incarnation_text(request.expected_incarnation)}"
            )
            refused = [SetResult(p.name, False, reason, ErrorCode.CONFLICT) for p in request.parameters]
            return [_result_to_wire(r) for r in refused], table.revision
        good = [p for p in params if p is not None]
        if bad and request.atomic:
            first = next(iter(bad.values())).name
            refused = [
                bad.get(i)
                or SetResult(
                    p.name, False, f"not applied: the atomic set failed on {first!r}", ErrorCode.INVALID_VALUE
                )
                for i, p in enumerate(request.parameters)
            ]
            return [_result_to_wire(r) for r in refused], table.revision
        setter = table.set_atomically if request.atomic else table.set
        with deadlines.applying(request.deadline):  # the table checks it right before its commit
            outcome = setter(good, expected_revision=expected)
        merged = iter(outcome.results)
        results = [bad[i] if i in bad else next(merged) for i in range(len(params))]
        return [_result_to_wire(r) for r in results], outcome.revision

    def _send_reply(self, topic: str, response: Any) -> None:
        """Write a reply; a failed write is logged and never loses the rest of the batch."""
        try:
            self._reply_writers[topic].write(response)
        except Exception as exc:
            who = response.client_id
            self._log_once(f"write:{topic}", "could not send a %s to client %x: %s", topic, who, exc)

    def _send_set_replies(self) -> None:
        """Send the set replies a worker's group wrote (one datagram per client reader)."""
        try:
            flush_writes(self._reply_writers["SetParametersResponse"])
        except Exception as exc:
            self._log_once("flush:SetParametersResponse", "could not send set replies: %s", exc)

    def _log_once(self, kind: str, message: str, *args: object) -> None:
        """Log a problem caused by peers once per kind, so a faulty peer cannot flood the log."""
        if kind not in self._logged_bad:
            self._logged_bad.add(kind)
            log.warning(message + " (further ones are not logged)", *args)

    def _remember(self, key: tuple[str, int, int], content: bytes, response: Any) -> None:
        """Keep the reply for retries: the newest DEDUP_WINDOW requests, DEDUP_BYTES at most."""
        with self._replies_lock:
            old = self._replies.pop(key, None)  # re-inserted at the end: the window keeps the newest
            if old is not None:
                self._replies_bytes -= len(old[0])
            self._replies[key] = (content, response)
            self._replies_bytes += len(content)
            while len(self._replies) > DEDUP_WINDOW or self._replies_bytes > DEDUP_BYTES:
                _, (dropped, _) = self._replies.popitem(last=False)
                self._replies_bytes -= len(dropped)

    def _on_get(self, samples: Sequence[Any]) -> None:
        self._answer(samples, "GetParametersResponse", self._fill_get)

    def _on_list(self, samples: Sequence[Any]) -> None:
        self._answer(samples, "ListParametersResponse", _fill_list)

    def _answer(self, samples: Sequence[Any], reply_topic: str, fill: Fill) -> None:
        """Answer read-only requests: at once when the node's worker is idle and its table
        free, else queued on the worker, in order with the node's sets."""
        for request in samples:
            if not request.sample_info.valid_data:
                continue
            worker = self._worker_for(request.node_id)
            if worker is None:
                self.foreign_requests += 1
                continue
            # nothing of this node's in flight (or its reads never wait for its writes): answer
            # now, skipping a thread hop
            if worker.idle() or worker.table.forwards_writes:
                with worker.table.try_locked() as free:  # never wait on a callback's lock
                    if free:
                        self._fill_and_reply(worker.table, request, reply_topic, fill)
                        continue
            worker.submit(partial(self._fill_and_reply, worker.table, request, reply_topic, fill))

    def _fill_get(self, table: HostedTable, request: Any, response: Any) -> None:
        history = self._histories.get(table.node_id)
        if request.history:
            if history is None:
                return  # history_kept stays FALSE
            page = history.query(query_from_wire(list(request.names), request.history[0]))
            response.history = [record_to_wire(r) for r in page.records]
            response.history_kept, response.history_more = True, page.more
            response.history_compacted = page.compacted
            return
        _fill_get(table, request, response)
        if request.with_descriptors and history is not None:
            for r in response.results:
                last = history.last(r.name) if not r.code else None
                if last is not None:
                    r.last_change = [last_change_to_wire(last)]

    def _fill_and_reply(self, table: HostedTable, request: Any, reply_topic: str, fill: Fill) -> None:
        """``fill(table, request, response)`` does the work; a refusal becomes the reply's code."""
        reply_type: Any = wire.TOPICS[reply_topic]
        response = reply_type(
            node_id=table.node_id,
            client_id=request.client_id,
            request_id=request.request_id,
            incarnation=self.incarnation(table.node_id),
        )
        try:
            fill(table, request, response)
            response.revision = table.revision
        except ParamddsError as exc:
            response.code, response.reason = exc.code.value, exc.message
        except Exception as exc:
            log.exception("%s on %s failed", type(request).__name__, table.node_id)
            response.code, response.reason = ErrorCode.INTERNAL.value, f"internal error: {exc}"
        self._send_reply(reply_topic, response)


def _manual_liveliness() -> Qos:
    return Qos(Policy.Liveliness.ManualByTopic(duration(seconds=LEASE)))


def _content(request: Any) -> bytes:
    """A set request's content as bytes (NaN equals itself here, unlike with ``==``): the
    bytes it arrived as (a retry is the same sample, written again), else encoded."""
    received = getattr(request, SERIALIZED, None)
    if isinstance(received, bytes):
        return received
    sample = wire.SetParametersRequest(
        atomic=request.atomic,
        expected_revision=request.expected_revision,
        parameters=request.parameters,
        expected_incarnation=request.expected_incarnation,
        deadline=request.deadline,
        who=request.who,
        via=request.via,
    )
    return encode(sample)


def _value_or_none(w: Any) -> ParameterValue | None:
    """A requested value as the core holds it; None if it is none (an unknown type byte)."""
    if w is None:
        return None
    try:
        return value_from_wire(w)
    except ParamddsError:
        return None


def _not_persisted(result: Any, revision: int, failure: str) -> Any:
    """An applied parameter whose change did not reach the disk."""
    if not result.successful:
        return result
    return wire.SetParameterResult(
        name=result.name,
        successful=False,
        reason=f"applied at revision {revision}, but not persisted: {failure}; "
        "the value holds until the server restarts",
        code=ErrorCode.NOT_PERSISTED.value,
    )


Fill = Callable[[HostedTable, Any, Any], None]


def _fill_get(table: HostedTable, request: Any, response: Any) -> None:
    check_request_size(len(request.names), "get")
    results = table.get_many(list(request.names), with_descriptors=request.with_descriptors)
    response.results = [
        wire.GetParameterResult(
            name=r.name,
            code=r.code.value if r.code else "",
            reason=r.reason,
            value=value_to_wire(r.value) if r.value is not None else wire.ParameterValue(),
            descriptor=[descriptor_to_wire(r.descriptor)] if r.descriptor is not None else [],
        )
        for r in results
    ]


def _fill_list(table: HostedTable, request: Any, response: Any) -> None:
    result = table.list(list(request.prefixes), int(request.depth))
    response.names, response.prefixes = list(result.names), list(result.prefixes)


def _result_to_wire(r: SetResult) -> Any:
    return wire.SetParameterResult(
        name=r.name, successful=r.successful, reason=r.reason, code=r.code.value if r.code else ""
    )


def _summary(response: Any) -> str:
    if response.code:
        return f"{response.code}: {response.reason}"
    return "; ".join(f"{r.name}: {r.reason}" for r in response.results if not r.successful)


def _decode_presence(data: bytes, info: Any) -> StateSample | StateKey:
    """A presence sample, or the key of an instance without data (its writers went)."""
    return decode_state(data) if info.valid_data else decode_key(data)
