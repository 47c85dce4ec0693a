"""The remote client: every site's nodes over Zenoh, named ``SITE/NODE``.

It has the shape of :class:`~paramdds.dds.client.ParameterClient` (a subclass, so the
CLI's verbs, :class:`~paramdds.dds.client.AsyncParameterClient` and the web console take
either), with the DDS machinery replaced by Zenoh queries, through the protected
interface of :class:`~paramdds.dds.client.ClientBase`. The remote monitor lives in
:mod:`.monitor` (its name is re-exported here); the state queries both make, in :mod:`.states`.

* the client sends each call as one query to the node's key, with an explicit Zenoh
  timeout, once Zenoh says a gateway of the site serves it (else UNAVAILABLE, and
  nothing is sent); no reply at all then means the route went meanwhile (UNAVAILABLE;
  OUTCOME_UNKNOWN for a set, which may have reached the gateway), or the answer did not
  come back in time (TIMEOUT).
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from typing import Any

import zenoh

from ..core.request import ParamsArg, to_parameters
from ..core.results import ListResult
from ..core.revision import Revision
from ..dds.client import (
    DEFAULT_TIMEOUT,
    ClientBase,
    GetReply,
    NodeInfo,
    ParameterClient,
    PendingCall,
    SetReply,
)
from ..dds.discovery import Presence
from ..errors import OutcomeUnknownError, ParamddsError, TimeoutError_, UnavailableError
from . import codec, keys
from .monitor import RemoteParameterMonitor as RemoteParameterMonitor  # its old home: re-exported
from .states import REPLY_MARGIN
from .states import ask_states as _ask_states
from .states import sites_of as _sites_of

log = logging.getLogger(__name__)

ROUTE_WAIT = 1.0  # seconds the first call of a verb to a site waits to learn a gateway serves it


def _states_of(
    session: Any, pattern: str, timeout: float, bad: list[str] | None = None
) -> list[codec.NodeStateMsg]:
    """Every node state the gateways answer for ``pattern`` (bounded by ``timeout``)."""
    return list(_ask_states(session, [pattern], timeout, bad))


def _states_by_site(session: Any, sites: Iterable[str], timeout: float) -> list[codec.NodeStateMsg]:
    """Every node state of ``sites``, a query per site (see :func:`_ask_states`)."""
    return list(_ask_states(session, [keys.site_pattern(site, keys.STATE) for site in sites], timeout))


class RemoteParameterClient(ParameterClient):
    """Calls to ``SITE/NODE`` over one Zenoh ``session``; every call bounded by its timeout.

    The calls (``list``, ``get``, ``get_value``, ``set`` with ``atomic`` and
    ``if_revision``, ``delete``, ``wait_for_node``, ``nodes``, ``node_info``,
    ``presence``) and the errors are those of
    :class:`~paramdds.dds.client.ParameterClient`; the node's own per-parameter
    results and codes come back unchanged.
    """

    def __init__(self, session: Any, *, timeout: float = DEFAULT_TIMEOUT) -> None:
        # the calls (ClientBase), carried by Zenoh queries instead of DDS: the hooks below
        ClientBase.__init__(self, timeout=timeout, client_id=0)
        self._session = session
        self._routes: dict[str, tuple[Any, float]] = {}  # a site's verb pattern -> (querier, declared at)
        self._routes_lock = threading.Lock()

    def close(self) -> None:
        ClientBase.close(self)  # not ParameterClient's: no DDS entities here
        with self._routes_lock:
            routes, self._routes = list(self._routes.values()), {}
        for querier, _ in routes:
            try:
                querier.undeclare()
            except Exception:
                log.debug("undeclaring %r failed", querier, exc_info=True)

    def _route(self, pending: PendingCall) -> tuple[Any, float]:
        """The querier on the site's pattern for the call's verb (declared on first use), and
        when it was declared."""
        pattern = keys.site_pattern(keys.split_remote(pending.node)[0], pending.topic)
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

    def _check_route(self, pending: PendingCall, limit: float) -> None:
        """UNAVAILABLE, before anything is sent, when no gateway of the node's site serves the
        call's verb now: Zenoh's matching status of a querier on the site's pattern (learnt
        from the router within milliseconds of its declaration, and lost as soon as the
        gateway's session is). A set that was never sent is a failure, not an unknown outcome.
        """
        querier, declared = self._route(pending)
        until = declared + min(ROUTE_WAIT, limit)
        while not self._matching(querier, pending):
            if time.monotonic() >= until:
                site = keys.split_remote(pending.node)[0]
                raise UnavailableError(
                    f"node {pending.node!r}: no gateway of site {site!r} is reachable (site not "
                    "connected, or its uplink is down); the call was not sent"
                )
            if self._closing.wait(0.005):
                raise UnavailableError("the client was closed")

    # -- presence --------------------------------------------------------------------------------

    def nodes(self) -> list[NodeInfo]:
        """Every node the gateways know (online or not), sorted by ``SITE/NODE``.

        Asked of the gateways now: a node is online as its gateway, which just answered,
        says (a liveliness get was not reliable enough in a one-shot call).
        """
        latest: dict[str, codec.NodeStateMsg] = {}
        for msg in _states_by_site(self._session, _sites_of(self._session, self.timeout), self.timeout):
            name = keys.remote_name(msg.site, msg.node)
            if name not in latest or latest[name].seq < msg.seq:
                latest[name] = msg
        return sorted((_info(m) for m in latest.values()), key=lambda n: n.node)

    def node_info(self, node: str) -> NodeInfo | None:
        site, nid = keys.split_remote(node)
        states = _states_of(self._session, keys.node_key(site, nid, keys.STATE), self.timeout)
        return _info(max(states, key=lambda m: m.seq)) if states else None

    def presence(self, node: str) -> Presence:
        """ONLINE, OFFLINE (its gateway knows it offline), or ABSENT (no gateway knows it)."""
        info = self.node_info(node)
        if info is None:
            return Presence.ABSENT
        return Presence.ONLINE if info.online else Presence.OFFLINE

    def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            remaining = deadline - time.monotonic()
            info = self.node_info(node) if remaining > 0 else None
            if info is not None and info.online:
                return info
            if remaining <= 0:
                if info is None:
                    raise UnavailableError(
                        f"node {node!r} is not present on any site reached (waited {limit:.2g} s)"
                    )
                raise UnavailableError(f"node {node!r} is offline (waited {limit:.2g} s)")
            if self._closing.wait(min(0.1, max(0.0, remaining))):
                raise UnavailableError("the client was closed")

    # -- the calls: ParameterClient's list/get/set/delete run these ------------------------------

    def _prepare(self, node: str, verb: str, body: dict[str, Any]) -> tuple[str, int, PendingCall]:
        site, nid = keys.split_remote(node)
        rid = self._next_id()
        pending = PendingCall(
            keys.remote_name(site, nid), verb, (keys.node_key(site, nid, verb), body), 0, None
        )
        return pending.node, rid, pending

    def _send_list(self, node: str, prefixes: Sequence[str], depth: int) -> tuple[str, int, PendingCall]:
        if depth < 0:
            raise ParamddsError(f"depth must be 0 (recursive) or positive, got {depth}")
        return self._prepare(node, "list", {"prefixes": list(prefixes), "depth": depth})

    def _send_get(
        self, node: str, names: Sequence[str], with_descriptors: bool
    ) -> tuple[str, int, PendingCall]:
        return self._prepare(node, "get", {"names": list(names), "with_descriptors": with_descriptors})

    def _send_set(
        self,
        node: str,
        params: ParamsArg,
        atomic: bool,
        if_revision: int | Revision | None,
        timeout: float | None = None,  # the gateway's call gets the query's (see _fire)
    ) -> tuple[str, int, PendingCall]:
        items = to_parameters(params)
        expected: object = None
        if isinstance(if_revision, Revision):
            expected = str(if_revision)
        elif if_revision is not None:
            expected = int(if_revision)
        body = {
            "parameters": [{"name": p.name, "value": codec.value_out(p.value)} for p in items],
            "atomic": atomic,
            "if_revision": expected,
        }
        return self._prepare(node, "set", body)

    def _fire(self, pending: PendingCall, timeout: float) -> Future[Any]:
        """Send the query; the future gets the reply's JSON object, or the error to raise."""
        key, body = pending.sample
        future: Future[Any] = pending.future
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
                    future.set_exception(exc)
                return
            waited = time.monotonic() - started
            if pending.topic == "set":  # sent: the gateway may have forwarded it (docs/reliability.md)
                future.set_exception(
                    OutcomeUnknownError(
                        f"outcome unknown: no answer from node {pending.node!r} within {timeout:g} s "
                        "through its site's gateway; the node refuses the set once its deadline has "
                        "passed, so a get then shows the outcome"
                    )
                )
            elif waited < timeout * 0.9:
                future.set_exception(
                    UnavailableError(
                        f"node {pending.node!r}: no gateway of its site answered "
                        f"(site not connected, or its uplink is down; waited {waited:.2g} s)"
                    )
                )
            else:
                future.set_exception(
                    TimeoutError_(f"no answer from node {pending.node!r} within {timeout:g} s")
                )

        payload = codec.dumps({**body, "timeout": timeout})
        try:
            self._session.get(
                key,
                zenoh.handlers.Callback(on_reply, on_done),
                payload=payload,
                encoding=codec.ENCODING,
                timeout=timeout + REPLY_MARGIN / 2,
                target=zenoh.QueryTarget.ALL,
                consolidation=zenoh.QueryConsolidation(zenoh.ConsolidationMode.NONE),
            )
        except Exception as exc:
            raise _unsent(pending, exc) from None
        return future

    def _wait(self, node: str, request_id: int, pending: PendingCall, timeout: float | None) -> Any:
        limit = self.timeout if timeout is None else timeout
        self._check_route(pending, limit)
        future = self._fire(pending, limit)
        try:
            return future.result(limit + REPLY_MARGIN)
        except FutureTimeout:
            raise TimeoutError_(f"no answer from node {node!r} within {limit:g} s") from None

    async def _await(self, node: str, request_id: int, pending: PendingCall, timeout: float | None) -> Any:
        limit = self.timeout if timeout is None else timeout
        if not self._matching(self._route(pending)[0], pending):  # else no thread hop: the usual case
            await asyncio.to_thread(self._check_route, pending, limit)  # may wait for the router
        future = asyncio.wrap_future(self._fire(pending, limit))
        try:
            return await asyncio.wait_for(future, limit + REPLY_MARGIN)
        except asyncio.TimeoutError:
            raise TimeoutError_(f"no answer from node {node!r} within {limit:g} s") from None

    def _finish_list(self, reply: Any) -> ListResult:
        obj = codec.check_reply(reply)
        return ListResult(tuple(str(n) for n in obj["names"]), tuple(str(p) for p in obj["prefixes"]))

    def _finish_get(self, reply: Any) -> GetReply:
        obj = codec.check_reply(reply)
        revision, incarnation, results = codec.get_results(obj)
        return GetReply(str(obj["node"]), revision, results, incarnation)

    def _finish_set(self, reply: Any) -> SetReply:
        obj = codec.check_reply(reply)
        revision, incarnation, results = codec.set_results(obj)
        return SetReply(str(obj["node"]), revision, results, incarnation)


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
