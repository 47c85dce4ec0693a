"""Clients: request/reply over the six request/reply topics, and node presence.

Correlation: every request carries this client's random 64-bit ``client_id`` and
a request id counted from 1. Reply readers are content-filtered on that
``client_id`` (a native filter reading it from the serialized reply, see
:mod:`.filters`), and the reply handler checks it again, so two clients (in one
process or two) never take each other's replies; replies are matched to calls by
request id. Many calls may be outstanding at once (pipelining).

Presence: the state reader is content-filtered on presence instances (name
``""``), so the parameters' state samples never reach Python here. They still reach
the process: a new reader is sent every server's retained state, so a one-shot
client (``one_shot``) creates that reader only when a call needs presence, and each
request topic's endpoints on its first call.

No call ever hangs: each has a timeout (default :data:`DEFAULT_TIMEOUT`). A node
that has no presence instance is reported UNAVAILABLE ("not present") only once
discovery has settled (:mod:`.discovery` states the rule: a state writer was found,
every matched one has delivered, and nothing changed for a quiet period that grows
with how slow discovery was); a node that goes offline while a call waits fails
that call with UNAVAILABLE; otherwise a missing answer is a TIMEOUT naming the
node, the time waited and how far discovery got. A request without a reply is sent
again (same ids) with backoff: the server answers repeats from its reply cache,
so a copy lost during discovery costs a fraction of a second, not the timeout.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import os
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass
from typing import Any

from cyclonedds.core import DDSException, InstanceState
from cyclonedds.domain import DomainParticipant

from ..core.deadline import deadline_for
from ..core.limits import check_request_size
from ..core.names import canonical_node_id
from ..core.request import ParamsArg, to_parameters
from ..core.results import GetResult, ListResult, SetResult
from ..core.revision import Revision
from ..core.values import NOT_SET, Parameter, ParameterValue
from ..errors import (
    NotFoundError,
    OutcomeUnknownError,
    ParamddsError,
    TimeoutError_,
    UnavailableError,
    code_of,
    error_for,
)
from .discovery import MIN_QUIET, DiscoveryState, DiscoveryWatch, Presence
from .dispatch import Dispatcher
from .filters import NativeFilter, filtered_topic, origin_of, request_filter_of, status_of
from .participant import peer_mismatches
from .qos import QosProfiles
from .transport import Writers, transport_of
from .wire import types as wire
from .wire.cdr import is_malformed
from .wire.convert import descriptor_from_wire, parameter_to_wire, value_from_wire

log = logging.getLogger(__name__)

DEFAULT_TIMEOUT = 5.0
PRESENCE_GRACE = MIN_QUIET  # the least quiet discovery time before a node without presence counts as absent
_READ_ALL = 1 << 24  # "every sample" for read(); Cyclone refuses N >= 2**28
PRESENCE_POLL = 0.02  # seconds between presence checks in wait_for_node
RESEND_AFTER = 0.2  # seconds without a reply before a call checks presence and resends
MATCH_POLL = 0.02  # seconds between checks, while a call waits, for a newly matched server
ONLINE_FRESH = 0.1  # seconds a write trusts a node's last "online" before looking again (see _check_unsent)
REQUEST_TOPICS = ("SetParametersRequest", "GetParametersRequest", "ListParametersRequest")


class _At:
    """A node's state as a reply or a presence reports it (the dataclasses below)."""

    incarnation: int
    revision: int

    @property
    def at(self) -> Revision:
        """(incarnation, revision): what ``set(..., if_revision=)`` compares."""
        return Revision(self.incarnation, self.revision)


@dataclass(frozen=True)
class NodeInfo(_At):
    """A node as its presence reports it: online, where it runs, its revision and size."""

    node: str
    online: bool
    host: str
    pid: int
    revision: int
    parameters: int
    request_filter: str | None = None  # how the server filters requests: "native", "handler", or unsaid
    incarnation: int = 0  # the server's for this node (new on every start); 0 from one without
    origin: str | None = None  # where the node comes from (presence tag "origin", "ros2" for a mirror)
    status: str | None = None  # presence tag "status": "unreachable", "stale" (a mirror), else None


@dataclass(frozen=True)
class GetReply(_At):
    """A node's answer to a get: a result per name asked, at the node's revision."""

    node: str
    revision: int
    results: tuple[GetResult, ...]
    incarnation: int = 0

    def values(self) -> dict[str, ParameterValue]:
        """The values found, by name (unknown names are in :meth:`missing`)."""
        return {r.name: r.value for r in self.results if r.value is not None}

    def missing(self) -> list[GetResult]:
        return [r for r in self.results if r.code is not None]


@dataclass(frozen=True)
class SetReply(_At):
    """A node's answer to a set: a result per parameter, and the node's revision after it."""

    node: str
    revision: int
    results: tuple[SetResult, ...]
    incarnation: int = 0  # the node's (on CONFLICT: its current one, with revision)

    @property
    def successful(self) -> bool:
        return all(r.successful for r in self.results)


class PendingCall:
    """One call in flight: its node, its topic (or verb), what was sent, and the future its
    reply (or the error to raise) is set on."""

    __slots__ = ("future", "matched", "node", "reached", "sample", "topic", "write", "writer")

    def __init__(self, node: str, topic: str, sample: Any, matched: int, writer: Any) -> None:
        self.node = node
        self.topic = topic
        self.write = topic == "SetParametersRequest"  # once it reached a node, no answer is OUTCOME_UNKNOWN
        self.reached = False  # a copy went out while a reader was matched (see ParameterClient._write)
        self.writer = writer
        self.sample = sample
        self.matched = matched  # the topic's match count when last looked at (see _newly_matched)
        self.future: Future[Any] = Future()


class ClientBase:
    """The calls of a client (:meth:`list`, :meth:`get`, :meth:`get_value`, :meth:`set`,
    :meth:`delete`), whatever carries them.

    :class:`ParameterClient` carries them on DDS. A client on another transport (the remote
    client of :mod:`paramdds.zenoh.remote`) subclasses ParameterClient, so that it is one
    wherever a client is taken (:class:`AsyncParameterClient` included), calls
    ``ClientBase.__init__`` instead of the DDS one, and implements these protected hooks,
    kept for them:

    * ``_send_list(node, prefixes, depth)``, ``_send_get(node, names, with_descriptors)``,
      ``_send_set(node, params, atomic, if_revision, timeout)``: make the call (sent now, or
      by the wait); return ``(node, request_id, PendingCall)``;
    * ``_wait(node, request_id, call, timeout)`` and ``async _await(...)``: the call's raw
      reply (``timeout`` None: :attr:`timeout`), or raise the error of the failure;
    * ``_finish_list(reply)``, ``_finish_get(reply)``, ``_finish_set(reply)``: the result;

    with ``_next_id()`` (request ids from 1) and ``_closing`` (an Event, set by :meth:`close`).
    """

    def __init__(self, *, timeout: float = DEFAULT_TIMEOUT, client_id: int = 0) -> None:
        self.timeout = timeout
        self.client_id = client_id
        self._ids = itertools.count(1)
        self._ids_lock = threading.Lock()
        self._closing = threading.Event()

    def close(self) -> None:
        self._closing.set()

    # -- the calls ------------------------------------------------------------------------

    def list(
        self, node: str, prefixes: Sequence[str] = (), depth: int = 0, *, timeout: float | None = None
    ) -> ListResult:
        return self._finish_list(self._wait(*self._send_list(node, prefixes, depth), timeout))

    def get(
        self, node: str, names: Sequence[str], *, with_descriptors: bool = False, timeout: float | None = None
    ) -> GetReply:
        """Values (and descriptors if asked) with a status per name; never an empty answer."""
        return self._finish_get(self._wait(*self._send_get(node, names, with_descriptors), timeout))

    def get_value(self, node: str, name: str, *, timeout: float | None = None) -> ParameterValue:
        (result,) = self.get(node, [name], timeout=timeout).results
        if result.value is None:
            raise NotFoundError(result.reason or f"parameter {name!r} not found on {node!r}")
        return result.value

    def set(
        self,
        node: str,
        params: ParamsArg,
        *,
        atomic: bool = False,
        if_revision: int | Revision | None = None,
        timeout: float | None = None,
    ) -> SetReply:
        """Set parameters: each on its own, or all-or-nothing with ``atomic``.

        ``if_revision`` applies the set only while the node is still at that state
        (compare-and-set); otherwise every result fails with CONFLICT and the reply
        carries the node's current :attr:`SetReply.at`. A :class:`Revision` (from
        ``NodeInfo.at``, ``GetReply.at``, ``SetReply.at``) compares the incarnation and
        the revision, so a restarted node never matches; a plain ``int`` compares the
        revision alone, which a restart can repeat.
        """
        return self._finish_set(
            self._wait(*self._send_set(node, params, atomic, if_revision, timeout), timeout)
        )

    def delete(self, node: str, names: Sequence[str], *, timeout: float | None = None) -> SetReply:
        return self.set(node, [Parameter(n, NOT_SET) for n in names], timeout=timeout)

    # -- the hooks of a transport (see the class doc) --------------------------------------

    def _next_id(self) -> int:
        with self._ids_lock:
            return next(self._ids)

    def _send_list(self, node: str, prefixes: Sequence[str], depth: int) -> tuple[str, int, PendingCall]:
        raise NotImplementedError

    def _send_get(
        self, node: str, names: Sequence[str], with_descriptors: bool
    ) -> tuple[str, int, PendingCall]:
        raise NotImplementedError

    def _send_set(
        self,
        node: str,
        params: ParamsArg,
        atomic: bool,
        if_revision: int | Revision | None,
        timeout: float | None = None,
    ) -> tuple[str, int, PendingCall]:
        raise NotImplementedError

    def _wait(self, node: str, request_id: int, pending: PendingCall, timeout: float | None) -> Any:
        raise NotImplementedError

    async def _await(self, node: str, request_id: int, pending: PendingCall, timeout: float | None) -> Any:
        raise NotImplementedError

    def _finish_list(self, reply: Any) -> ListResult:
        raise NotImplementedError

    def _finish_get(self, reply: Any) -> GetReply:
        raise NotImplementedError

    def _finish_set(self, reply: Any) -> SetReply:
        raise NotImplementedError


class ParameterClient(ClientBase):
    """A synchronous client. Thread-safe; use one per process (or several: they never mix).

    ``presence_grace`` is the least time discovery must stay quiet before a node never
    seen counts as absent (:mod:`.discovery`); it is no longer a fixed deadline.
    ``one_shot`` is for processes that make a call or a few, such as the CLI's verbs: the
    presence reader is created only once a call needs it (see :meth:`_watch`), and a
    request topic's writer and reply reader on its first call (a long-lived client makes
    them now, so they are matched before its first call).
    """

    def __init__(
        self,
        participant: DomainParticipant,
        qos: QosProfiles | None = None,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        presence_grace: float = PRESENCE_GRACE,
        client_id: int | None = None,
        one_shot: bool = False,
    ) -> None:
        # os.urandom, not secrets: the same random bits without importing hmac, hashlib and random
        super().__init__(timeout=timeout, client_id=client_id or int.from_bytes(os.urandom(8), "little") or 1)
        self._dp = participant
        self._qos = qos or QosProfiles.load()
        self._pending: dict[int, PendingCall] = {}
        # secure mode (.transport): a writer per target node, each in that node's partition,
        # and a topic's endpoints made on its first call (a viewer may never set)
        self._transport = transport_of(participant)
        self._writers: dict[str, Any] = {}
        self._dispatcher = Dispatcher(participant, "paramdds-client")
        self._reply_filter = NativeFilter("client")
        self._reply_filter.set_client_id(self.client_id)
        self._reply_readers: dict[str, Any] = {}  # by request topic
        self._match_counts: dict[int, int] = {}  # by id() of the request writer (one per node when secure)
        self._endpoints_lock = threading.Lock()
        self._made = Writers(self._transport, opening=self._open_topic)
        for request in () if one_shot else REQUEST_TOPICS:  # plain: one writer per topic, made now
            writer = self._made.early(request, self._qos.writer(request))
            if writer is not None:
                self._writers[request] = writer
        self._presence_filter = NativeFilter("presence")
        self._presence_filter.set_nodes(None)  # every node's presence, no parameter samples
        self._presence_args = (participant, presence_grace)
        self._presence: Any = None  # the presence reader and its discovery watch: see _watch
        self._online_at: dict[str, float] = {}  # node -> when a write last found it online
        self._discovery: DiscoveryWatch | None = None
        self._watch_lock = threading.Lock()
        if not one_shot:
            self._watch()
        self._dispatcher.start()

    def _open_topic(self, request: str) -> None:
        """The reply reader of one request topic (made before its first request writer)."""
        name = request.replace("Request", "Response")
        reader = self._transport.reader(self._own_replies(name), self._qos.reader(name))
        self._reply_readers[request] = reader
        self._dispatcher.add(reader, self._transport.guard(reader, self._on_replies))

    def _writer_for(self, topic: str, node: str) -> Any:
        """The writer of ``topic`` for ``node``: the one writer, or in secure mode that node's."""
        found = self._writers.get(topic)
        if found is not None:
            return found
        with self._endpoints_lock:
            return self._made.get(topic, node, self._qos.writer(topic))

    def _watch(self) -> DiscoveryWatch:
        """The presence reader's discovery watch, creating both on first use.

        A new ``ParameterEvents`` reader is sent every server's retained state (all of
        its parameters: the filter drops them only on arrival), so a one-shot process
        (``one_shot``) creates it only when a call needs presence: a reply late by
        :data:`RESEND_AFTER`, :meth:`wait_for_node`, :meth:`nodes`, :meth:`presence`.
        """
        with self._watch_lock:
            if self._discovery is None:
                participant, grace = self._presence_args
                topic = filtered_topic(
                    participant, "ParameterEvents", wire.ParameterEvent, self._presence_filter
                )
                # secure: a few samples per instance, to skip one a writer had no right to write
                qos = self._transport.history(self._qos.reader("ParameterEvents"))
                self._presence = self._transport.reader(topic, qos)
                self._discovery = DiscoveryWatch(
                    participant,
                    self._presence,
                    [*self._writers.values(), *self._reply_readers.values()],
                    min_quiet=grace,
                )
            return self._discovery

    def _own_replies(self, name: str) -> Any:
        # without the native filter every client's replies arrive; _on_replies keeps ours
        return filtered_topic(self._dp, name, wire.TOPICS[name], self._reply_filter)

    def close(self) -> None:
        self._closing.set()
        self._dispatcher.close()
        with self._watch_lock:
            if self._discovery is not None:
                self._discovery.close()
        for pending in list(self._pending.values()):
            if not pending.future.done():
                pending.future.set_exception(_closed_error(pending))
        self._pending.clear()

    def __enter__(self) -> ParameterClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- presence -------------------------------------------------------------------
    #
    # The presence reader is never drained by the dispatcher: Cyclone keeps each
    # instance's last sample serialized, and we decode only the presence instance of
    # the node asked about (lookup_instance + read). Taking every ParameterEvents
    # sample instead would make each client decode the whole system's state.

    def _presence_of(self, node: str) -> NodeInfo | None:
        watch = self._watch()
        handle = self._presence.lookup_instance(wire.ParameterEvent(node_id=node, name=""))
        if handle is None:
            return None
        try:
            samples: list[Any] = self._presence.read(
                N=self._transport.samples_per_instance, instance_handle=handle
            )
        except DDSException:
            # the handle is process-wide: another entity here may know the key while
            # this reader holds no such instance (PRECONDITION_NOT_MET)
            return None
        watch.note_read(s.sample_info for s in samples)
        samples = self._believed(samples)
        return _node_info(samples[-1]) if samples else None

    def _believed(self, samples: list[Any]) -> list[Any]:
        """Secure mode: the presence samples whose writers may write their node's partition
        (a sample without data, which names no node, says nothing and is dropped)."""
        return self._transport.believed(self._presence, samples)

    def nodes(self) -> list[NodeInfo]:
        """Every node whose presence this client holds (alive or not), sorted by name."""
        watch = self._watch()
        samples: list[Any] = self._presence.read(N=_READ_ALL)
        watch.note_read(s.sample_info for s in samples)
        # a node's samples come oldest first, so its last presence wins; samples without data
        # (a node its server stopped hosting) and parameter samples give None
        found = (_node_info(s) for s in self._believed(samples))
        latest = {n.node: n for n in found if n is not None}
        return sorted(latest.values(), key=lambda n: n.node)

    def node_info(self, node: str) -> NodeInfo | None:
        return self._presence_of(canonical_node_id(node))

    def discovery(self) -> DiscoveryState:
        """How far this client's discovery of the system has got (see :mod:`.discovery`)."""
        return self._watch().state()

    def ignore_writer(self, writer: Any) -> None:
        """Leave a ``ParameterEvents`` writer of this process out of :meth:`discovery`
        (see :meth:`DiscoveryWatch.ignore`)."""
        self._watch().ignore(writer)

    def presence(self, node: str) -> Presence:
        """ONLINE, OFFLINE, ABSENT (discovery settled without it) or UNKNOWN (it may yet appear).

        The one place that decides whether a node "is not present": the calls, the
        CLI and a web console all ask this.
        """
        info = self._presence_of(canonical_node_id(node))
        if info is not None:
            return Presence.ONLINE if info.online else Presence.OFFLINE
        return Presence.ABSENT if self._watch().settled() else Presence.UNKNOWN

    def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        """Block until ``node`` is online, for up to ``timeout`` seconds.

        A node that does not come online in time raises UnavailableError when it is
        offline or absent by the rule of :mod:`.discovery`, and TimeoutError_ (saying
        how far discovery got) while discovery is still in progress. Checks every
        :data:`PRESENCE_POLL` seconds (a start-up wait, not a data path).
        """
        node = canonical_node_id(node)
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            info = self._presence_of(node)
            if info is not None and info.online:
                return info
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise self._not_seen(node, limit)
            self._watch().state()  # moves discovery on: asks again (a probe) when nobody answered
            self._closing.wait(min(remaining, PRESENCE_POLL))
            if self._closing.is_set():
                raise UnavailableError("the client was closed")

    # -- plumbing shared by the sync and async forms ---------------------------------------

    def _send(self, topic: str, node: str, sample: Any) -> tuple[str, int, PendingCall]:
        writer = self._writer_for(topic, node)
        pending = PendingCall(node, topic, sample, self._match_counts.get(id(writer), 0), writer)
        self._pending[sample.request_id] = pending
        try:
            _write(pending)
        except Exception as exc:
            del self._pending[sample.request_id]
            raise ParamddsError(f"could not send the request to {node!r}: {exc}") from exc
        return node, sample.request_id, pending

    def _send_list(self, node: str, prefixes: Sequence[str], depth: int) -> tuple[str, int, PendingCall]:
        node = canonical_node_id(node)
        if depth < 0:
            raise ParamddsError(f"depth must be 0 (recursive) or positive, got {depth}")
        sample = wire.ListParametersRequest(
            node_id=node,
            client_id=self.client_id,
            request_id=self._next_id(),
            depth=depth,
            prefixes=list(prefixes),
        )
        return self._send("ListParametersRequest", node, sample)

    def _send_get(
        self, node: str, names: Sequence[str], with_descriptors: bool
    ) -> tuple[str, int, PendingCall]:
        node = canonical_node_id(node)
        check_request_size(len(names), "get")
        sample = wire.GetParametersRequest(
            node_id=node,
            client_id=self.client_id,
            request_id=self._next_id(),
            with_descriptors=with_descriptors,
            names=list(names),
        )
        return self._send("GetParametersRequest", node, sample)

    def _send_set(
        self,
        node: str,
        params: ParamsArg,
        atomic: bool,
        if_revision: int | Revision | None,
        timeout: float | None = None,
    ) -> tuple[str, int, PendingCall]:
        node = canonical_node_id(node)
        expected = _expected(if_revision)
        parameters = [parameter_to_wire(p) for p in to_parameters(params)]
        self._check_unsent(node)
        sample = wire.SetParametersRequest(
            node_id=node,
            client_id=self.client_id,
            request_id=self._next_id(),
            atomic=atomic,
            expected_revision=expected.revision,
            parameters=parameters,
            expected_incarnation=expected.incarnation,
            deadline=deadline_for(self.timeout if timeout is None else timeout),
        )
        return self._send("SetParametersRequest", node, sample)

    def _check_unsent(self, node: str) -> None:
        """A write to a node this client already knows to be offline or absent is not sent:
        UNAVAILABLE is then true (the request never left this process). A client that does not
        watch presence yet (``one_shot``) sends at once, and learns later.

        The verdict "online" is trusted for :data:`ONLINE_FRESH` seconds (presence itself lags
        by up to the 1 s lease): a write that is sent is never reported failed, so a stale
        "online" costs only a slower, still true, answer; the lookup costs ~25 µs a set."""
        seen = self._online_at.get(node)
        if self._discovery is None or (seen is not None and time.monotonic() - seen < ONLINE_FRESH):
            return
        state = self.presence(node)
        if state is Presence.ONLINE:
            self._online_at[node] = time.monotonic()
        elif state is Presence.OFFLINE:
            raise UnavailableError(f"node {node!r} is offline: the request was not sent")
        if state is Presence.ABSENT:
            why = self._watch().state().describe()
            raise UnavailableError(f"node {node!r} is not present ({why}): the request was not sent")

    def _on_replies(self, samples: Sequence[Any]) -> None:
        me = self.client_id
        for reply in samples:
            if not reply.sample_info.valid_data or reply.client_id != me:
                continue
            pending = self._pending.pop(reply.request_id, None)
            if pending is not None and not pending.future.done():
                pending.future.set_result(reply)

    def _not_seen(self, node: str, waited: float) -> ParamddsError:
        """The error for a node not (or no longer) online after ``waited`` seconds."""
        state = self.presence(node)
        if state is Presence.OFFLINE:
            return UnavailableError(f"node {node!r} is offline (waited {waited:.2g} s)")
        why = self._watch().state().describe()
        also = self._mismatched()
        if state is Presence.ABSENT:
            return UnavailableError(f"node {node!r} is not present ({why}; waited {waited:.2g} s){also}")
        return TimeoutError_(f"node {node!r} not seen within {waited:.2g} s: {why}{also}")

    def _slices(self, pending: PendingCall, timeout: float | None) -> Iterator[float]:
        """How long to wait for the reply next; raises once the call cannot succeed.

        A request is sent again (the first copy can be lost while a just-started
        client or server is still being discovered: a VOLATILE writer does not send
        a sample to a reader it matches later, nor a server's reply writer to a
        client's reader):

        * at once when the request writer or the reply reader of its topic has
          matched a new peer since the request was sent (checked every
          :data:`MATCH_POLL` seconds while the call waits);
        * after :data:`RESEND_AFTER` seconds without a reply, doubling up to 1 s.
          Before that resend, a node that is offline (within a step of its
          liveliness lease for one that died) or absent (never seen, and discovery
          settled: :meth:`presence`) is UNAVAILABLE.

        Retries are safe: the server answers a repeated (client_id, request_id)
        from its reply cache. A present node that does not answer is a TIMEOUT at
        ``timeout``; a node never seen while discovery is still in progress is a
        TIMEOUT that says so.
        """
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit  # the request's own deadline is earlier (deadline_for)
        step = RESEND_AFTER
        next_resend = time.monotonic() + step
        seen = self._discovery.state() if self._discovery is not None else None
        while True:
            now = time.monotonic()
            if now >= deadline:
                if _may_apply(pending):  # it reached a node: it may have been applied
                    raise self._outcome_unknown(pending.node, limit)
                if self.presence(pending.node) is not Presence.ONLINE:
                    raise self._not_seen(pending.node, limit)
                why = self._mismatched()
                raise TimeoutError_(f"no answer from node {pending.node!r} within {limit:g} s{why}")
            yield max(0.0, min(deadline, next_resend, now + MATCH_POLL) - now)
            now = time.monotonic()
            if self._discovery is not None:
                state = self._discovery.state()  # keeps the time of the last discovery change precise
                # a write waits on: its node may come back and answer
                news = _news(seen, state) and not _may_apply(pending)
                if news and self.presence(pending.node) in (Presence.OFFLINE, Presence.ABSENT):
                    raise self._not_seen(pending.node, now - (deadline - limit))
                seen = state
            if now >= next_resend:
                step = min(2 * step, 1.0)  # a big request that is merely slow is not resent often
                next_resend = now + step
                gone = (Presence.OFFLINE, Presence.ABSENT)
                if not _may_apply(pending) and self.presence(pending.node) in gone:
                    raise self._not_seen(pending.node, now - (deadline - limit))
            elif not self._newly_matched(pending):
                continue
            try:
                _write(pending)
            except Exception as exc:
                log.debug("resending request %d failed: %s", pending.sample.request_id, exc)

    def _outcome_unknown(self, node: str, waited: float) -> OutcomeUnknownError:
        """The error for a write sent and not answered within its caller's ``waited`` seconds."""
        state = self.presence(node)
        now = {
            Presence.OFFLINE: " (it is offline now)",
            Presence.ABSENT: f" (it is not present: {self._watch().state().describe()})",
        }.get(state, "")
        return OutcomeUnknownError(
            f"outcome unknown: no answer from node {node!r}{now} within {waited:g} s of sending the "
            "request, so it may or may not have been applied; its deadline has passed, so the node "
            "will not apply it from now on (with clocks in sync): `get` shows the outcome"
            + self._mismatched()
        )

    def _mismatched(self) -> str:
        """A note for a failed call when peers were refused for their type or QoS (see :mod:`.peers`)."""
        found = peer_mismatches(self._dp)
        if not found:
            return ""
        n = len(found)
        return f" ({n} DDS peer endpoint(s) do not match ours and are ignored, e.g. {found[0].message()})"

    def _newly_matched(self, pending: PendingCall) -> bool:
        """Whether the topic of ``pending`` has matched a new peer since the count was last taken."""
        topic = pending.topic
        writer: Any = pending.writer  # the binding's status getters are untyped
        count = (
            writer.get_publication_matched_status().total_count
            + self._reply_readers[topic].get_subscription_matched_status().total_count
        )
        self._match_counts[id(writer)] = count
        if count == pending.matched:
            return False
        pending.matched = count
        return True

    def _wait(self, node: str, request_id: int, pending: PendingCall, timeout: float | None) -> Any:
        try:
            for step in self._slices(pending, timeout):
                try:
                    return pending.future.result(step)
                except FutureTimeout:
                    continue
            raise AssertionError("unreachable")  # _slices raises before it ends
        finally:
            self._pending.pop(request_id, None)

    async def _await(self, node: str, request_id: int, pending: PendingCall, timeout: float | None) -> Any:
        future = asyncio.wrap_future(pending.future)
        try:
            for step in self._slices(pending, timeout):
                done, _ = await asyncio.wait({future}, timeout=step)
                if done:
                    return future.result()
            raise AssertionError("unreachable")
        finally:
            self._pending.pop(request_id, None)
            if not future.done():
                future.cancel()

    @staticmethod
    def _check(reply: Any) -> None:
        if reply.code:
            raise error_for(reply.code, reply.reason or reply.code)

    def _finish_list(self, reply: Any) -> ListResult:
        self._check(reply)
        return ListResult(tuple(reply.names), tuple(reply.prefixes))

    def _finish_get(self, reply: Any) -> GetReply:
        self._check(reply)
        results = []
        for r in reply.results:
            code = code_of(r.code)
            results.append(
                GetResult(
                    name=r.name,
                    value=None if code else value_from_wire(r.value),
                    descriptor=descriptor_from_wire(r.descriptor[0]) if r.descriptor else None,
                    code=code,
                    reason=r.reason,
                )
            )
        return GetReply(reply.node_id, reply.revision, tuple(results), reply.incarnation)

    def _finish_set(self, reply: Any) -> SetReply:
        self._check(reply)
        results = tuple(SetResult(r.name, r.successful, r.reason, code_of(r.code)) for r in reply.results)
        return SetReply(reply.node_id, reply.revision, results, reply.incarnation)


class AsyncParameterClient:
    """The asyncio form of :class:`ParameterClient` (same calls, awaitable, pipelining-friendly)."""

    def __init__(self, client: ParameterClient) -> None:
        self.sync = client

    async def list(
        self, node: str, prefixes: Sequence[str] = (), depth: int = 0, *, timeout: float | None = None
    ) -> ListResult:
        c = self.sync
        return c._finish_list(await c._await(*c._send_list(node, prefixes, depth), timeout))

    async def get(
        self, node: str, names: Sequence[str], *, with_descriptors: bool = False, timeout: float | None = None
    ) -> GetReply:
        c = self.sync
        return c._finish_get(await c._await(*c._send_get(node, names, with_descriptors), timeout))

    async def set(
        self,
        node: str,
        params: ParamsArg,
        *,
        atomic: bool = False,
        if_revision: int | Revision | None = None,
        timeout: float | None = None,
    ) -> SetReply:
        c = self.sync
        sent = c._send_set(node, params, atomic, if_revision, timeout)
        return c._finish_set(await c._await(*sent, timeout))

    async def delete(self, node: str, names: Sequence[str], *, timeout: float | None = None) -> SetReply:
        return await self.set(node, [Parameter(n, NOT_SET) for n in names], timeout=timeout)

    async def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        return await asyncio.to_thread(self.sync.wait_for_node, node, timeout)


def _news(seen: DiscoveryState | None, state: DiscoveryState) -> bool:
    """Whether discovery has just settled, or a state writer's liveliness changed (a server died).

    A waiting call then looks at its node's presence at once, not at its next resend
    (up to 1 s later): a node of a server killed while the call waits is UNAVAILABLE
    about a second after the death (the writer's 1 s lease), whatever the timeout.
    """
    if seen is None:
        return state.settled
    return (state.settled and not seen.settled) or state.liveliness != seen.liveliness


def _write(pending: PendingCall) -> None:
    """Send (or send again) ``pending``'s request, noting whether a copy can have reached a node:
    a VOLATILE writer with no matched reader delivers to no one, then or later (a reader that
    matches later gets a resend, see ``_slices``), so a write that never met a reader was never
    sent and cannot be applied (secure mode without a valid identity: nobody matches)."""
    writer: Any = pending.writer  # the binding's status getters are untyped
    if not pending.write or pending.reached:
        writer.write(pending.sample)
        return
    before = writer.get_publication_matched_status().current_count
    writer.write(pending.sample)
    pending.reached = bool(before or writer.get_publication_matched_status().current_count)


def _may_apply(pending: PendingCall) -> bool:
    """A write that can have reached its node: without an answer, its outcome is unknown."""
    return pending.write and pending.reached


def _closed_error(pending: PendingCall) -> ParamddsError:
    """The error of a call still waiting when its client is closed."""
    if _may_apply(pending):
        return OutcomeUnknownError(
            f"outcome unknown: the client was closed before node {pending.node!r} answered; "
            "the request was sent and may have been applied"
        )
    return UnavailableError("the client was closed")


def _node_info(sample: Any) -> NodeInfo | None:
    """The presence carried by a ParameterEvents sample, or None for a parameter sample."""
    info = sample.sample_info
    if not info.valid_data or is_malformed(sample) or sample.kind != wire.EVENT_PRESENCE:
        return None
    online = info.instance_state == InstanceState.Alive
    tags = sample.value.string_array_value  # the server's tags, if it writes any
    return NodeInfo(
        sample.node_id,
        online,
        sample.host,
        sample.pid,
        sample.revision,
        sample.parameter_count,
        request_filter_of(tags),
        sample.incarnation,
        origin_of(tags),
        status_of(tags),
    )


def _expected(if_revision: int | Revision | None) -> Revision:
    """What a set request compares: (0, -1) nothing, (0, n) the revision alone."""
    if if_revision is None:
        return Revision(0, -1)
    expected = if_revision if isinstance(if_revision, Revision) else Revision(0, if_revision)
    incarnation, revision = expected
    if not (isinstance(incarnation, int) and isinstance(revision, int)):
        raise ParamddsError(f"if_revision must be an int or a Revision, got {if_revision!r}")
    if not expected.on_wire():
        raise ParamddsError(f"if_revision out of range: {if_revision!r}")
    return expected
