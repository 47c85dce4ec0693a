"""The client: list, get, set and delete parameters of a node, and its presence, on any transport.

One :class:`ParameterClient` runs each call's life (:mod:`paramdds.core.call`: request
ids, the deadline, resends, which failure it ends with) over a transport that
implements :class:`~.client_protocol.ClientTransport`: DDS
(:class:`~.client_transport.DdsClientTransport`, built from a participant) or Zenoh
(:func:`paramdds.zenoh.client.RemoteParameterClient`). :class:`AsyncParameterClient`
is its asyncio form.

No call ever hangs: each has a timeout (default :data:`DEFAULT_TIMEOUT`). A node that
is not present is reported UNAVAILABLE; a node that goes offline while a call waits
fails that call with UNAVAILABLE; otherwise a missing answer is a TIMEOUT naming the
node and the time waited, and a set that may have reached its node is OUTCOME_UNKNOWN
(a set whose node no server ever announced is held and fails UNAVAILABLE: it cannot land).
On DDS a request without a reply is sent again (same ids) with backoff, from
:data:`RESEND_AFTER` seconds, and at once when a new peer matches (checked every
:data:`MATCH_POLL` seconds): the server answers repeats from its reply cache, so a
copy lost during discovery costs a fraction of a second, not the timeout.
"""

from __future__ import annotations

import asyncio
import builtins
import itertools
import logging
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import TimeoutError as FutureTimeout
from typing import Any

from cyclonedds.domain import DomainParticipant

from ..core.call import Call, Failure, GetRequest, HistoryRequest, ListRequest, Request, SetRequest, Wake
from ..core.history import HistoryPage, HistoryQuery, Outcome
from ..core.history_pages import HistoryPages, TimeArg
from ..core.origin import Via, local_identity, via_text
from ..core.replies import GetReply, HistoryReply, NodeInfo, SetReply
from ..core.request import ParamsArg
from ..core.results import ListResult
from ..core.revision import Revision
from ..core.values import NOT_SET, Parameter, ParameterValue
from ..errors import NotFoundError, ParamddsError
from .client_protocol import ClientTransport, PendingCall
from .client_transport import ONLINE_FRESH, PRESENCE_GRACE, PRESENCE_POLL, REQUEST_TOPICS, DdsClientTransport
from .discovery import DiscoveryState, Presence
from .qos import QosProfiles

__all__ = [
    "DEFAULT_TIMEOUT",
    "MATCH_POLL",
    "ONLINE_FRESH",
    "PRESENCE_GRACE",
    "PRESENCE_POLL",
    "REQUEST_TOPICS",
    "RESEND_AFTER",
    "AsyncParameterClient",
    "ClientTransport",
    "GetReply",
    "NodeInfo",
    "ParameterClient",
    "PendingCall",
    "SetReply",
]

log = logging.getLogger(__name__)

DEFAULT_TIMEOUT = 5.0
RESEND_AFTER = 0.2  # seconds without a reply before a call checks presence and resends
MATCH_POLL = 0.02  # seconds between checks, while a call waits, for a newly matched server


class ParameterClient:
    """A synchronous client. Thread-safe; use one per process (or several: they never mix).

    ``ParameterClient(participant, qos, ...)`` carries the calls on DDS: ``presence_grace``,
    ``client_id`` and ``one_shot`` are those of
    :class:`~.client_transport.DdsClientTransport` (``one_shot``: for processes that make a
    call or a few, such as the CLI's verbs, whose presence reader and endpoints are made
    on first use). ``ParameterClient(transport)`` takes any
    :class:`~.client_protocol.ClientTransport`.
    """

    def __init__(
        self,
        participant: DomainParticipant | ClientTransport,
        qos: QosProfiles | None = None,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        presence_grace: float = PRESENCE_GRACE,
        client_id: int | None = None,
        one_shot: bool = False,
        as_: str | None = None,
        via: Via | str = Via.API,
    ) -> None:
        """``as_``: the identity this client's writes claim (default ``$PARAMDDS_AS``, else
        ``USER@host``); ``via``: the channel they are recorded under."""
        self.timeout = timeout
        self.who = as_ or local_identity()
        self.via = via_text(via)
        self._ids = itertools.count(1)
        self._ids_lock = threading.Lock()
        if isinstance(participant, ClientTransport):
            if qos is not None or client_id is not None or one_shot:
                raise TypeError("qos, client_id and one_shot are the DDS transport's: give them to it")
            self.transport: ClientTransport = participant
        else:
            self.transport = DdsClientTransport(
                participant, qos, presence_grace=presence_grace, client_id=client_id, one_shot=one_shot
            )

    @property
    def client_id(self) -> int:
        """Echoed in every reply to this client (0: its transport correlates replies itself)."""
        return self.transport.client_id

    def close(self) -> None:
        self.transport.close()

    def __enter__(self) -> ParameterClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the calls ------------------------------------------------------------------------

    def list(
        self, node: str, prefixes: Sequence[str] = (), depth: int = 0, *, timeout: float | None = None
    ) -> ListResult:
        return self.transport.list_result(self._run(ListRequest(node, tuple(prefixes), depth), timeout))

    def get(
        self, node: str, names: Sequence[str], *, with_descriptors: bool = False, timeout: float | None = None
    ) -> GetReply:
        """Values (and descriptors if asked) with a status per name; never an empty answer."""
        return self.transport.get_reply(self._run(GetRequest(node, tuple(names), with_descriptors), timeout))

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
        as_: str | None = None,
    ) -> SetReply:
        """Set parameters: each on its own, or all-or-nothing with ``atomic``.

        ``if_revision`` applies the set only while the node is still at that state
        (compare-and-set); otherwise every result fails with CONFLICT and the reply
        carries the node's current :attr:`SetReply.at`. A :class:`Revision` (from
        ``NodeInfo.at``, ``GetReply.at``, ``SetReply.at``) compares the incarnation and
        the revision, so a restarted node never matches; a plain ``int`` compares the
        revision alone, which a restart can repeat. ``as_`` claims another identity than the
        client's for this write.
        """
        request = self.set_request(node, params, atomic, if_revision, as_)
        return self.transport.set_reply(self._run(request, timeout))

    def delete(self, node: str, names: Sequence[str], *, timeout: float | None = None) -> SetReply:
        return self.set(node, [Parameter(n, NOT_SET) for n in names], timeout=timeout)

    def history(
        self,
        node: str,
        names: Sequence[str] = (),
        *,
        since_revision: int | None = None,
        since_time: TimeArg = None,
        until: TimeArg = None,
        who: str = "",
        outcome: Outcome = Outcome.ALL,
        timeout: float | None = None,
    ) -> HistoryReply:
        """The node's changes (and refused writes) matching every filter given, oldest first:
        of ``names`` (all when empty), after revision ``since_revision``, from ``since_time``
        to ``until`` (datetimes or seconds since the epoch), by a ``who`` glob. ``compacted``
        says retention dropped part of the range. NoHistoryError: the node keeps none."""
        pages = HistoryPages(
            node, tuple(names), since_revision=since_revision, since_time=since_time, until=until,
            who=who, outcome=outcome,
        )  # fmt: skip
        while not pages.take(*self.history_page(node, pages.query, timeout=timeout)):
            pass
        return pages.reply()

    def history_page(
        self, node: str, query: HistoryQuery, *, timeout: float | None = None
    ) -> tuple[bool, HistoryPage]:
        """One page of the node's history as it answers ``query`` (what :meth:`history`
        walks): whether it keeps any, and the page."""
        return self.transport.history_page(self._run(HistoryRequest(node, query), timeout))

    def set_request(
        self,
        node: str,
        params: ParamsArg,
        atomic: bool = False,
        if_revision: int | Revision | None = None,
        as_: str | None = None,
    ) -> SetRequest:
        """A set as this client sends it: with its identity (or ``as_``) and its channel."""
        return SetRequest(node, params, atomic, if_revision, as_ or self.who, self.via)

    # -- presence ---------------------------------------------------------------------------

    def nodes(self) -> builtins.list[NodeInfo]:
        """Every node whose presence this client knows (online or not), sorted by name."""
        return self.transport.nodes()

    def node_info(self, node: str) -> NodeInfo | None:
        return self.transport.node_info(node)

    def presence(self, node: str) -> Presence:
        """ONLINE, OFFLINE, ABSENT (it is not there) or UNKNOWN (it may yet appear).

        The one place that decides whether a node "is not present": the calls, the
        CLI and a web console all ask this.
        """
        return self.transport.presence(node)

    def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        """Block until ``node`` is online, for up to ``timeout`` seconds.

        A node that does not come online in time raises UnavailableError when it is
        offline or absent, and CallTimeoutError (saying how far discovery got) while DDS
        discovery is still in progress.
        """
        return self.transport.wait_for_node(node, self.timeout if timeout is None else timeout)

    def discovery(self) -> DiscoveryState:
        """How far this client's DDS discovery of the system has got (see :mod:`.discovery`)."""
        return self._dds().discovery()

    def ignore_writer(self, writer: Any) -> None:
        """Leave a ``ParameterEvents`` writer of this process out of :meth:`discovery`
        (see :meth:`DiscoveryWatch.ignore`)."""
        self._dds().ignore_writer(writer)

    def _dds(self) -> DdsClientTransport:
        if not isinstance(self.transport, DdsClientTransport):
            carrier = type(self.transport).__name__
            raise ParamddsError(f"discovery is DDS's; this client is carried by {carrier}")
        return self.transport

    # -- a call's life, for this client and an event loop's (AsyncParameterClient) ------------

    def begin(self, request: Request, timeout: float | None) -> PendingCall:
        """Start a call (checked and encoded by the transport, not sent yet)."""
        resends = self.transport.resends
        call = Call(
            self.transport.canonical(request.node),
            self._next_id(),
            request.write,
            self.timeout if timeout is None else timeout,
            time.monotonic(),
            resend_after=RESEND_AFTER if resends else None,
            match_poll=MATCH_POLL,
            grace=self.transport.grace,
        )
        return self.transport.start(request, call)

    def slices(self, pending: PendingCall) -> Iterator[float]:
        """How long to wait for the reply next, after :meth:`ClientTransport.send`; raises
        once the call cannot succeed (the rules are :mod:`paramdds.core.call`'s)."""
        t, call = self.transport, pending.call

        def look() -> Presence:
            return t.presence(call.node)

        if call.resends:
            call.watch(t.discovery_mark())
        while True:
            now = time.monotonic()
            if call.expired(now):
                raise t.error(pending, call.verdict(look, now), call.timeout)
            yield call.wait(now)
            if not call.resends:
                continue
            now = time.monotonic()
            mark = t.discovery_mark()
            news = mark is not None and call.news(mark)
            resend = call.wake(now) is Wake.RESEND
            if (news or resend or call.holding) and call.lost(look, now):
                raise t.error(pending, Failure.NOT_SEEN, call.waited(now))
            if call.holding or not (resend or t.newly_matched(pending)):
                continue  # a write held to make sure it never lands sends no copy
            try:
                t.send(pending)
            except Exception as exc:
                log.debug("resending request %d failed: %s", call.request_id, exc)

    def _run(self, request: Request, timeout: float | None) -> Any:
        """The raw reply of one call (the transport reads it), or the error of its failure."""
        pending = self.begin(request, timeout)
        try:
            self.transport.route(pending)
            self.transport.send(pending)
            for step in self.slices(pending):
                try:
                    return pending.future.result(step)
                except FutureTimeout:
                    continue
            raise AssertionError("unreachable")  # slices raises before it ends
        finally:
            self.transport.finish(pending)

    def _next_id(self) -> int:
        with self._ids_lock:
            return next(self._ids)


class AsyncParameterClient:
    """The asyncio form of :class:`ParameterClient` (same calls, awaitable, pipelining-friendly)."""

    def __init__(self, client: ParameterClient) -> None:
        self.sync = client

    async def list(
        self, node: str, prefixes: Sequence[str] = (), depth: int = 0, *, timeout: float | None = None
    ) -> ListResult:
        reply = await self._run(ListRequest(node, tuple(prefixes), depth), timeout)
        return self.sync.transport.list_result(reply)

    async def get(
        self, node: str, names: Sequence[str], *, with_descriptors: bool = False, timeout: float | None = None
    ) -> GetReply:
        reply = await self._run(GetRequest(node, tuple(names), with_descriptors), timeout)
        return self.sync.transport.get_reply(reply)

    async def set(
        self,
        node: str,
        params: ParamsArg,
        *,
        atomic: bool = False,
        if_revision: int | Revision | None = None,
        timeout: float | None = None,
        as_: str | None = None,
    ) -> SetReply:
        reply = await self._run(self.sync.set_request(node, params, atomic, if_revision, as_), timeout)
        return self.sync.transport.set_reply(reply)

    async def history(
        self,
        node: str,
        names: Sequence[str] = (),
        *,
        since_revision: int | None = None,
        since_time: TimeArg = None,
        until: TimeArg = None,
        who: str = "",
        outcome: Outcome = Outcome.ALL,
        timeout: float | None = None,
    ) -> HistoryReply:
        pages = HistoryPages(
            node, tuple(names), since_revision=since_revision, since_time=since_time, until=until,
            who=who, outcome=outcome,
        )  # fmt: skip
        while not pages.take(*self.sync.transport.history_page(await self._run(pages.request(), timeout))):
            pass
        return pages.reply()

    async def delete(self, node: str, names: Sequence[str], *, timeout: float | None = None) -> SetReply:
        return await self.set(node, [Parameter(n, NOT_SET) for n in names], timeout=timeout)

    async def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        return await asyncio.to_thread(self.sync.wait_for_node, node, timeout)

    async def _run(self, request: Request, timeout: float | None) -> Any:
        client = self.sync
        transport = client.transport
        pending = client.begin(request, timeout)
        future = asyncio.wrap_future(pending.future)
        try:
            if transport.route_known(pending):
                transport.route(pending)
            else:  # the route may take the transport a while to learn: not on the event loop
                await asyncio.to_thread(transport.route, pending)
            transport.send(pending)
            for step in client.slices(pending):
                done, _ = await asyncio.wait({future}, timeout=step)
                if done:
                    return future.result()
            raise AssertionError("unreachable")
        finally:
            transport.finish(pending)
            if not future.done():
                future.cancel()
