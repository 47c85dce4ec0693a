"""The Zenoh transport of a client: calls to ``SITE/NODE`` as Zenoh queries through each site's gateway.

Each call is one query to the node's key, with an explicit Zenoh timeout (the call's),
sent once Zenoh says a gateway of the site serves the call's verb (else UNAVAILABLE,
and nothing is sent). The query's end says how the call ended: a reply is the answer;
none at all means the route went meanwhile (UNAVAILABLE when it ended early; a set,
which may have reached the gateway, is OUTCOME_UNKNOWN) or the answer did not come
back in time (TIMEOUT). Nothing is sent again: Zenoh's routing does not lose a
query the way a VOLATILE DDS writer loses a sample before it matches.

Presence is asked of the gateways (they know every node of their site).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import zenoh

from ..core.call import Call, Failure, GetRequest, HistoryRequest, ListRequest, Mark, Request, closed_error
from ..core.history import HistoryPage
from ..core.origin import AS_ENV, Via, local_identity
from ..core.replies import GetReply, NodeInfo, SetReply
from ..core.request import to_parameters
from ..core.results import ListResult
from ..core.revision import Revision
from ..dds.client import DEFAULT_TIMEOUT, ParameterClient
from ..dds.client_protocol import PendingCall
from ..dds.discovery import Presence
from ..errors import (
    CallTimeoutError,
    NoHistoryError,
    NotPermittedError,
    OutcomeUnknownError,
    ParamddsError,
    UnavailableError,
)
from . import codec, history, keys
from .states import GRANT_ASK, REPLY_MARGIN, ROUTE_WAIT, ask_states, site_active, sites_of
from .tls import certificate_name

log = logging.getLogger(__name__)

__all__ = ["REPLY_MARGIN", "ROUTE_WAIT", "RemoteParameterClient", "ZenohClientTransport", "remote_identity"]



def RemoteParameterClient(
    session: Any, *, timeout: float = DEFAULT_TIMEOUT, as_: str | None = None
) -> ParameterClient:
    """A :class:`~paramdds.dds.client.ParameterClient` of ``SITE/NODE`` over one Zenoh
    ``session``; every call bounded by its timeout.

    The calls (``list``, ``get``, ``get_value``, ``set`` with ``atomic`` and
    ``if_revision``, ``delete``, ``history``, ``wait_for_node``, ``nodes``,
    ``node_info``, ``presence``) and the errors are those of the DDS client; the node's
    own per-parameter results and codes come back unchanged. Its writes are recorded on
    the node as ``as_`` (default :func:`remote_identity`) via ``zenoh``, unverified.
    """
    transport = ZenohClientTransport(session, timeout=timeout)
    return ParameterClient(transport, timeout=timeout, as_=as_ or remote_identity(), via=Via.ZENOH)


def remote_identity(environ: Mapping[str, str] | None = None) -> str:
    """The identity a remote client claims: ``$PARAMDDS_AS``, else the common name of the
    certificate in ``$PARAMDDS_ZENOH_TLS`` (its ``cert.pem``), else ``USER@host``."""
    env = os.environ if environ is None else environ
    if env.get(AS_ENV):
        return env[AS_ENV]
    tls_dir = env.get("PARAMDDS_ZENOH_TLS", "").strip()
    name = certificate_name(Path(tls_dir) / "cert.pem") if tls_dir else None
    return name or local_identity()


class ZenohClientTransport:
    """A client's calls and presence over Zenoh (a
    :class:`~paramdds.dds.client_protocol.ClientTransport`); ``timeout`` bounds the
    presence queries."""

    client_id = 0  # a query's reply comes back to its query: no correlation needed
    resends = False
    grace = REPLY_MARGIN

    def __init__(self, session: Any, *, timeout: float = DEFAULT_TIMEOUT) -> None:
        self._session = session
        self._timeout = timeout
        self._closing = threading.Event()
        self._pending: dict[int, PendingCall] = {}
        self._routes: dict[str, tuple[Any, float]] = {}  # a site's verb pattern -> (querier, declared at)
        self._routes_lock = threading.Lock()

    def close(self) -> None:
        self._closing.set()
        with self._routes_lock:
            routes, self._routes = list(self._routes.values()), {}
        for querier, _ in routes:
            try:
                querier.undeclare()
            except Exception:
                log.debug("undeclaring %r failed", querier, exc_info=True)
        for pending in list(self._pending.values()):
            if not pending.future.done():
                pending.future.set_exception(closed_error(pending.call))
        self._pending.clear()

    # -- a call ---------------------------------------------------------------------------

    def canonical(self, node: str) -> str:
        return keys.remote_name(*keys.split_remote(node))

    def start(self, request: Request, call: Call) -> PendingCall:
        body: dict[str, Any]
        if isinstance(request, ListRequest):
            if request.depth < 0:
                raise ParamddsError(f"depth must be 0 (recursive) or positive, got {request.depth}")
            verb, body = "list", {"prefixes": list(request.prefixes), "depth": request.depth}
        elif isinstance(request, GetRequest):
            verb, body = "get", {"names": list(request.names), "with_descriptors": request.with_descriptors}
        elif isinstance(request, HistoryRequest):
            verb, body = "history", history.query_out(request.query)
        else:
            items = to_parameters(request.params)
            expected: object = None
            if isinstance(request.if_revision, Revision):
                expected = str(request.if_revision)
            elif request.if_revision is not None:
                expected = int(request.if_revision)
            verb, body = "set", {
                "parameters": [{"name": p.name, "value": codec.value_out(p.value)} for p in items],
                "atomic": request.atomic,
                "if_revision": expected,
                "who": request.who,
            }
        site, nid = keys.split_remote(call.node)
        pending = PendingCall(call, verb, (keys.node_key(site, nid, verb), body))
        self._pending[call.request_id] = pending
        return pending

    def _querier(self, pending: PendingCall, verb: str = "") -> tuple[Any, float]:
        """The querier on the site's pattern for the call's verb (or ``verb``; declared on
        first use), and when it was declared."""
        pattern = keys.site_pattern(keys.split_remote(pending.node)[0], verb or pending.kind)
        with self._routes_lock:
            route = self._routes.get(pattern)
            if route is None:
                try:
                    route = self._routes[pattern] = (self._session.declare_querier(pattern), time.monotonic())
                except Exception as exc:
                    raise _unsent(pending, exc) from None
        return route

    @staticmethod
    def _matching(querier: Any, pending: PendingCall) -> bool:
        try:
            return bool(querier.matching_status.matching)
        except Exception as exc:  # the session was closed under us
            raise _unsent(pending, exc) from None

    def route_known(self, pending: PendingCall) -> bool:
        return self._matching(self._querier(pending)[0], pending)  # else no thread hop: the usual case

    def route(self, pending: PendingCall) -> None:
        """UNAVAILABLE, before anything is sent, when no gateway of the node's site serves the
        call's verb now: Zenoh's matching status of a querier on the site's pattern (learnt
        from the router within milliseconds of its declaration, and lost as soon as the
        gateway's session is). A set that was never sent is a failure, not an unknown outcome.
        A history call to a site whose gateway serves calls but not history (an older
        paramdds) fails NO_HISTORY, as a node that keeps none does.
        """
        querier, declared = self._querier(pending)
        until = declared + min(ROUTE_WAIT, pending.call.timeout)
        while not self._matching(querier, pending):
            if time.monotonic() >= until:
                site = keys.split_remote(pending.node)[0]
                if site_active(self._session, site) and not self._matching(querier, pending):
                    if pending.kind == "history" and self._serves(pending, "get"):
                        raise NoHistoryError(
                            f"node {pending.node!r}: the gateway of site {site!r} serves no history "
                            "(an older paramdds); the call was not sent"
                        )
                    raise NotPermittedError(
                        f"node {pending.node!r}: site {site!r} is not granted to this client (its "
                        "gateway is up, but the router's access control refuses this certificate "
                        "the site); the call was not sent"
                    )
                raise UnavailableError(
                    f"node {pending.node!r}: no gateway of site {site!r} is reachable (site not "
                    "connected, or its uplink is down); the call was not sent"
                )
            if self._closing.wait(0.005):
                raise UnavailableError("the client was closed")

    def _serves(self, pending: PendingCall, verb: str) -> bool:
        """Whether a gateway of the node's site serves ``verb`` to this client (asked for up
        to :data:`~.states.GRANT_ASK` seconds)."""
        querier, _ = self._querier(pending, verb)
        until = time.monotonic() + GRANT_ASK
        while not self._matching(querier, pending):
            if time.monotonic() >= until or self._closing.wait(0.005):
                return False
        return True

    def send(self, pending: PendingCall) -> None:
        """Send the query; its future gets the reply's JSON object, or the error to raise."""
        key, body = pending.message
        call, future = pending.call, pending.future
        started = time.monotonic()
        replies: list[bytes] = []

        def on_reply(reply: Any) -> None:
            sample = reply.ok
            if sample is not None:
                replies.append(sample.payload.to_bytes())
            elif reply.err is not None and not future.done():
                text = reply.err.payload.to_bytes().decode(errors="replace")
                future.set_exception(ParamddsError(f"the gateway refused the call on {key}: {text}"))

        def on_done() -> None:
            if future.done():
                return
            if replies:
                try:
                    future.set_result(codec.loads(replies[0], f"the reply of {pending.node!r}"))
                except ParamddsError as exc:
                    future.set_exception(_unreadable(pending, exc))
                return
            waited = time.monotonic() - started
            future.set_exception(self.error(pending, call.unanswered(waited), waited))

        payload = codec.dumps({**body, "timeout": call.timeout})
        call.sent(True)  # sent: the gateway may forward it (docs/reliability.md)
        try:
            self._session.get(
                key,
                zenoh.handlers.Callback(on_reply, on_done),
                payload=payload,
                encoding=codec.ENCODING,
                timeout=call.timeout + REPLY_MARGIN / 2,
                target=zenoh.QueryTarget.ALL,
                consolidation=zenoh.QueryConsolidation(zenoh.ConsolidationMode.NONE),
            )
        except Exception as exc:
            raise _unsent(pending, exc) from None

    def newly_matched(self, pending: PendingCall) -> bool:
        return False

    def discovery_mark(self) -> Mark | None:
        return None

    def error(self, pending: PendingCall, failure: Failure, waited: float) -> ParamddsError:
        node, timeout = pending.node, pending.call.timeout
        if failure is Failure.OUTCOME_UNKNOWN:
            return OutcomeUnknownError(
                f"outcome unknown: no answer from node {node!r} within {timeout:g} s "
                "through its site's gateway; the node refuses the set once its deadline has "
                "passed, so a get then shows the outcome"
            )
        if failure is Failure.NO_ROUTE:
            return UnavailableError(
                f"node {node!r}: no gateway of its site answered "
                f"(site not connected, or its uplink is down; waited {waited:.2g} s)"
            )
        if failure is Failure.CLOSED:
            return closed_error(pending.call)
        if failure is Failure.NOT_SEEN:
            return UnavailableError(f"node {node!r} is not present on any site reached ({waited:.2g} s)")
        return CallTimeoutError(f"no answer from node {node!r} within {timeout:g} s")

    def finish(self, pending: PendingCall) -> None:
        self._pending.pop(pending.call.request_id, None)

    # -- replies --------------------------------------------------------------------------

    def list_result(self, reply: Any) -> ListResult:
        obj = codec.check_reply(reply)
        return ListResult(tuple(str(n) for n in obj["names"]), tuple(str(p) for p in obj["prefixes"]))

    def get_reply(self, reply: Any) -> GetReply:
        obj = codec.check_reply(reply)
        revision, incarnation, results = codec.get_results(obj)
        return GetReply(str(obj["node"]), revision, results, incarnation)

    def set_reply(self, reply: Any) -> SetReply:
        obj = codec.check_reply(reply)
        revision, incarnation, results = codec.set_results(obj)
        return SetReply(str(obj["node"]), revision, results, incarnation)

    def history_page(self, reply: Any) -> tuple[bool, HistoryPage]:
        page, kept = history.page_of(codec.check_reply(reply))
        return kept, page

    # -- presence -------------------------------------------------------------------------

    def nodes(self) -> list[NodeInfo]:
        """Every node the gateways know (online or not), sorted by ``SITE/NODE``.

        Asked of the gateways now: a node is online as its gateway, which just answered,
        says (a liveliness get was not reliable enough in a one-shot call).
        """

        sites = sites_of(self._session, self._timeout)
        patterns = [keys.site_pattern(site, keys.STATE) for site in sites]
        latest: dict[str, codec.NodeStateMsg] = {}
        for msg in ask_states(self._session, patterns, self._timeout):
            name = keys.remote_name(msg.site, msg.node)
            if name not in latest or latest[name].seq < msg.seq:
                latest[name] = msg
        return sorted((_info(m) for m in latest.values()), key=lambda n: n.node)

    def node_info(self, node: str) -> NodeInfo | None:

        site, nid = keys.split_remote(node)
        states = list(ask_states(self._session, [keys.node_key(site, nid, keys.STATE)], self._timeout))
        return _info(max(states, key=lambda m: m.seq)) if states else None

    def presence(self, node: str) -> Presence:
        """ONLINE, OFFLINE (its gateway knows it offline), or ABSENT (no gateway knows it)."""
        info = self.node_info(node)
        if info is None:
            return Presence.ABSENT
        return Presence.ONLINE if info.online else Presence.OFFLINE

    def wait_for_node(self, node: str, timeout: float) -> NodeInfo:
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            info = self.node_info(node) if remaining > 0 else None
            if info is not None and info.online:
                return info
            if remaining <= 0:
                if info is None:
                    raise UnavailableError(
                        f"node {node!r} is not present on any site reached (waited {timeout:.2g} s)"
                    )
                raise UnavailableError(f"node {node!r} is offline (waited {timeout:.2g} s)")
            if self._closing.wait(min(0.1, max(0.0, remaining))):
                raise UnavailableError("the client was closed")


def _unreadable(pending: PendingCall, exc: ParamddsError) -> ParamddsError:
    """The error of a reply that arrived but does not decode (Zenoh can splice its framing
    into a payload: docs/zenoh.md "Limits"): a write's outcome is then unknown (its node may
    have applied it), a read is UNAVAILABLE (a fault on the way, not of the node: ask again)."""
    if not pending.call.write:
        return UnavailableError(f"the reply of node {pending.node!r} arrived damaged ({exc}); ask again")
    return OutcomeUnknownError(
        f"outcome unknown: the reply of node {pending.node!r} arrived damaged ({exc}); the write "
        "reached its gateway and may have been applied: `get` or `history` shows the outcome"
    )


def _unsent(pending: PendingCall, exc: Exception) -> UnavailableError:
    """A call Zenoh would not take (the session closed, a key it refused): nothing was sent."""
    return UnavailableError(f"could not send the call to {pending.node!r}: {exc}")


def _info(msg: codec.NodeStateMsg) -> NodeInfo:
    return NodeInfo(
        keys.remote_name(msg.site, msg.node),
        msg.online,
        msg.host,
        msg.pid,
        msg.revision,
        msg.announced if msg.announced >= 0 else len(msg.parameters),
        None,
        msg.incarnation,
        msg.origin,
        msg.status,
    )
