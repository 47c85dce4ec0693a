"""The gateway: one site's DDS domain on Zenoh (``paramdds zenoh --site NAME``).

On the DDS side it is an ordinary paramdds participant: a
:class:`~paramdds.dds.monitor.ParameterMonitor` holds every node's current state and a
:class:`~paramdds.dds.client.ParameterClient` calls the nodes. On the Zenoh side
(:mod:`.keys` is the contract):

* every change of a node (a parameter, its presence) marks it; a publisher thread
  publishes each marked node's whole state once on ``.../state`` (changes within
  :data:`BATCH` seconds share one publication). The routers fan it out: one copy
  crosses the uplink whatever the number of remote viewers;
* a ``complete`` queryable on ``paramdds/<site>/node/*/state`` answers from the
  monitor's current state (never from history): one query gives a fresh remote client
  every node of the site exactly, offline nodes included;
* a liveliness token ``.../alive`` is held per online node, so remote viewers see a
  node, or the whole site when the gateway or its uplink dies, go offline;
* queryables on ``.../get``, ``.../list``, ``.../set`` and ``.../history`` forward
  calls to the node and reply with per-parameter results and codes (history: one page
  per query); every call is bounded by the request's timeout (capped at
  :data:`MAX_CALL_TIMEOUT`). A forwarded write is recorded on the node via ``zenoh``,
  as the identity the remote asker claims, unverified: neither the gateway nor the node
  can check who asked (the router authenticated the asker's certificate, and tells no
  one), and the node takes the gateway's word only;
* each node's state carries each parameter's last change (who, verified, via, when,
  revision), as the gateway's monitor holds it.

Standby: several gateways may serve one site. Each holds a token
``paramdds/<site>/gateway/<start>_<zid>`` (its start time in ns since the epoch and
its Zenoh id), and the active one also ``.../gateway/<start>_<zid>/active/<since>``
(when it took the role). A gateway that sees an active one stands by: it keeps its DDS
state warm and declares nothing else. When no active one is left (it died, or its
uplink did), the standby started first takes over at once: it declares the node tokens
and queryables and publishes every node. A gateway whose uplink was cut stays active
on its side of the cut (it sees no other gateway); when the link returns it sees the
one that took over meanwhile, active since later than itself, and steps aside: the
role stays where the remote viewers were served, and the site's nodes are not handed
back (two active gateways keep the one active since latest).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from typing import Any

import zenoh

from ..core.history import HistoryQuery
from ..core.origin import Via
from ..core.results import LastChange
from ..dds.client import ParameterClient
from ..dds.monitor import MonitorEvent, NodeState, ParameterMonitor
from ..errors import InternalError, InvalidNameError, NotPermittedError, ParamddsError
from . import codec, grant, history, keys

log = logging.getLogger(__name__)

BATCH = 0.02  # seconds: changes of one node within this share one publication
MAX_CALL_TIMEOUT = 60.0  # seconds: the longest a forwarded call may wait on the site
DEFAULT_CALL_TIMEOUT = 5.0
ELECTION_WAIT = 1.0  # seconds: how long a starting gateway asks for the site's other gateways
WORKERS = 8  # forwarded calls and state queries served at once
SYNC_WAIT = 3.0  # seconds: the most a starting gateway waits for its site's current state
UNSAID = "unknown"  # who a forwarded write is recorded as when its asker does not say (an older client)


class Gateway:
    """Serve ``site``'s nodes (seen through ``participant``) on the Zenoh ``session``."""

    def __init__(
        self,
        participant: Any,
        session: Any,
        site: str,
        *,
        qos: Any = None,
        on_role: Callable[[bool], None] | None = None,
        open_probe: Callable[[], Any] | None = None,
    ) -> None:
        self.site = keys.check_site(site)
        self._session = session
        self.zid = str(session.zid())
        self.token_id = f"{time.time_ns()}_{self.zid}"  # earliest start wins the election
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._role_lock = threading.Lock()
        self._dirty: set[str] = set()
        self._seq: dict[str, int] = {}
        # node -> its parameters last published: value, descriptor, last change
        self._published: dict[str, dict[str, tuple[Any, Any, LastChange | None]]] = {}
        self._heads: dict[str, tuple[object, ...]] = {}  # node -> the rest of its last publication
        self._tokens: dict[str, Any] = {}
        self._gateways: set[str] = set()
        self._actives: dict[str, int] = {}  # the other active gateways: token id -> active since (ns)
        self._active = False
        self._since = 0  # when this gateway took the active role (ns since the epoch)
        self._closed = False
        self._declared: list[Any] = []
        self.on_role = on_role
        self._pool = ThreadPoolExecutor(max_workers=WORKERS, thread_name_prefix="paramdds-zenoh")
        # every write it forwards is recorded on the node via zenoh, as the remote asker claims
        self.client = ParameterClient(participant, qos, timeout=DEFAULT_CALL_TIMEOUT, via=Via.ZENOH)
        self.monitor = ParameterMonitor(participant, qos, on_event=self._on_event)
        self._publisher = threading.Thread(target=self._publish_loop, name="paramdds-zenoh-pub", daemon=True)
        self._publisher.start()
        # the site's current state first, so that a gateway taking the active role publishes it all
        self.monitor.wait_synced(SYNC_WAIT)
        live = session.liveliness()
        self._gateway_token = live.declare_token(keys.gateway_key(self.site, self.token_id))
        self._gateway_sub: Any = None
        if open_probe is not None:  # the router may refuse this certificate the site: stop, saying so
            self._check_grant(open_probe)
        pattern = keys.gateway_key(self.site, "**")  # the gateways' tokens and the active one's
        # who else serves this site: asked once (bounded), then followed
        for reply in live.get(pattern, timeout=ELECTION_WAIT):
            if reply.ok is not None:
                self._note_gateway(str(reply.ok.key_expr), alive=True)
        self._gateway_sub = live.declare_subscriber(pattern, self._on_gateway, history=True)
        with self._lock:
            self._gateways.add(self.token_id)
        self._elect()

    def _check_grant(self, open_probe: Callable[[], Any]) -> None:
        """Stop (NotPermittedError) when the router says it holds no token of this gateway
        (:mod:`.grant`): its certificate is not granted the site, so nothing it declared or
        would publish reaches anyone. When the router cannot be asked, go on and say so."""
        token = keys.gateway_key(self.site, self.token_id)
        verdict = grant.check_token(self._session, open_probe, token)
        if verdict is grant.Grant.REFUSED:
            self.close()
            raise NotPermittedError(
                f"this gateway's certificate is not granted site {self.site!r}: the router holds no "
                f"token of it {grant.REFUSED_AFTER:g} s after its declaration, so nothing of the site "
                "would reach anyone (grant it the site: the router's --grant); stopping"
            )
        if verdict is grant.Grant.UNKNOWN:
            log.warning(
                "could not ask the router whether it holds this gateway's token within %g s: "
                "serving site %s without knowing that its certificate is granted the site",
                grant.GIVE_UP_AFTER,
                self.site,
            )

    # -- the election -------------------------------------------------------------------------

    def _on_gateway(self, sample: Any) -> None:
        self._note_gateway(str(sample.key_expr), alive=sample.kind != zenoh.SampleKind.DELETE)
        self._submit(self._elect)

    def _note_gateway(self, key: str, *, alive: bool) -> None:
        try:
            gateway, since = keys.parse_gateway_key(key)
        except InvalidNameError:
            log.warning("ignoring a token on %s", key)
            return
        with self._lock:
            if since is not None:
                if gateway == self.token_id:
                    return  # this gateway's own
                if alive:
                    self._actives[gateway] = since
                else:
                    self._actives.pop(gateway, None)
            elif alive:
                self._gateways.add(gateway)
            else:
                self._gateways.discard(gateway)
                self._actives.pop(gateway, None)
            self._gateways.add(self.token_id)

    def _wants_active(self) -> bool:
        """The rule (under ``_lock``): an active gateway keeps the role unless another one is
        active since later (it took over while this one was cut off); a standby takes it when
        no other is active and it is the first started of those it sees."""
        if self._active:
            mine = (self._since, self.token_id)
            return all((since, g) < mine for g, since in self._actives.items())
        return not self._actives and min(self._gateways, key=_election_key) == self.token_id

    @property
    def active(self) -> bool:
        return self._active

    def _elect(self) -> None:
        with self._role_lock:  # one change of role at a time: declarations never interleave
            with self._lock:
                if self._closed:
                    return
                want = self._wants_active()
                if want == self._active:
                    return
                self._active = want
            if want:
                self._activate()
            else:
                self._deactivate()
        log.info("gateway %s for site %s is now %s", self.zid, self.site, "active" if want else "standby")
        if self.on_role is not None:
            self.on_role(want)

    def _activate(self) -> None:
        s, site = self._session, self.site
        self._since = time.time_ns()
        declared = [
            s.liveliness().declare_token(keys.active_key(site, self.token_id, self._since)),
            s.declare_queryable(keys.site_pattern(site, keys.STATE), self._on_state_query, complete=True),
            *(
                s.declare_queryable(keys.site_pattern(site, verb), self._on_call, complete=True)
                for verb in keys.VERBS
            ),
        ]
        with self._lock:
            self._published, self._heads = {}, {}  # the first publication of each node from now on is whole
            self._declared = declared
            self._dirty.update(self._node_ids())  # publish every node once: the new active one speaks
            self._wake.notify_all()

    def _deactivate(self) -> None:
        with self._lock:
            declared, self._declared = self._declared, []
            tokens, self._tokens = self._tokens, {}
        for entity in [*declared, *tokens.values()]:
            _undeclare(entity)

    def _node_ids(self) -> list[str]:
        out: list[str] = []

        def take(states: dict[str, NodeState]) -> bool:
            out.extend(states)
            return True

        self.monitor.wait_until(take, 0.0)
        return out

    # -- state: events -> publications -------------------------------------------------------------

    def _on_event(self, event: MonitorEvent) -> None:
        if not event.node:  # "synced"
            return
        with self._lock:
            self._dirty.add(event.node)
            self._wake.notify_all()

    def _publish_loop(self) -> None:
        while True:
            with self._lock:
                while not self._dirty and not self._closed:
                    self._wake.wait()
                if self._closed:
                    return
            time.sleep(BATCH)  # let the rest of one change arrive
            with self._lock:
                dirty, self._dirty = self._dirty, set()
                active = self._active
            if not active:
                continue
            for node in sorted(dirty):
                try:
                    self._publish(node)
                except Exception:  # a failing put must not end the loop
                    log.exception("publishing node %r failed", node)

    def _publish(self, node: str) -> None:
        msg = self._state_of(node, bump=True)
        if msg is None:
            return
        key = keys.node_key(self.site, node, keys.STATE)
        blame = msg.last_changes
        full = {n: (v, d, blame.get(n)) for n, (v, d) in msg.parameters.items()}
        before = self._published.get(node)
        if before is not None:  # only what changed since the last publication (codec: "delta")
            msg.kind, msg.base = "delta", msg.seq - 1
            msg.deleted = [n for n in before if n not in full]
            msg.parameters = {
                n: (v, d)
                for n, (v, d, lc) in full.items()
                if n not in before or not before[n][0].same_as(v) or before[n][1:] != (d, lc)
            }
        head = (msg.online, msg.host, msg.pid, msg.revision, msg.incarnation, msg.announced, msg.origin)
        if not msg.parameters and not msg.deleted and self._heads.get(node) == (*head, msg.status):
            with self._lock:  # nothing new to say (a write published already): the next one follows the last
                self._seq[node] -= 1
            return
        self._session.put(key, msg.encode(), encoding=codec.ENCODING)
        self._published[node] = full
        self._heads[node] = (*head, msg.status)
        with self._lock:
            token = self._tokens.get(node)
            if msg.online and token is None and self._active:
                self._tokens[node] = self._session.liveliness().declare_token(
                    keys.node_key(self.site, node, keys.ALIVE)
                )
            elif not msg.online and token is not None:
                del self._tokens[node]
            else:
                token = None
        if token is not None:
            _undeclare(token)

    def _state_of(self, node: str, *, bump: bool) -> codec.NodeStateMsg | None:
        found: list[NodeState] = []

        def take(states: dict[str, NodeState]) -> bool:
            st = states.get(node)
            if st is not None:  # a copy of this node only (the monitor's snapshot copies them all)
                found.append(
                    NodeState(
                        st.node,
                        st.online,
                        st.host,
                        st.pid,
                        st.revision,
                        st.announced,
                        incarnation=st.incarnation,
                        origin=st.origin,
                        status=st.status,
                        parameters=dict(st.parameters),
                        blame=dict(st.blame),
                    )
                )
            return True

        self.monitor.wait_until(take, 0.0)
        if not found:
            return None
        st = found[0]
        with self._lock:
            seq = self._seq.get(node, 0) + (1 if bump else 0)
            self._seq[node] = seq
        return codec.NodeStateMsg(
            site=self.site,
            node=node,
            gateway=self.zid,
            seq=seq,
            online=st.online,
            host=st.host,
            pid=st.pid,
            revision=st.revision,
            incarnation=st.incarnation,
            announced=st.announced,
            origin=st.origin,
            status=st.status,
            parameters=st.parameters,
            last_changes={n: lc for n in st.blame if (lc := st.last_change(n)) is not None},
        )

    def _submit(self, fn: Callable[..., object], *args: Any) -> bool:
        """Run ``fn`` on the pool (never on Zenoh's thread); False once the gateway is closing."""
        try:
            self._pool.submit(fn, *args)
        except RuntimeError:  # shut down
            return False
        return True

    def _on_state_query(self, query: Any) -> None:
        if not self._submit(self._answer_state, query):
            query.drop()

    def _answer_state(self, query: Any) -> None:
        with query:
            asked = query.key_expr
            for node in self._node_ids():
                key = keys.node_key(self.site, node, keys.STATE)
                if not asked.intersects(key):
                    continue
                msg = self._state_of(node, bump=False)
                if msg is not None:
                    query.reply(key, msg.encode(), encoding=codec.ENCODING)

    # -- calls --------------------------------------------------------------------------------------

    def _on_call(self, query: Any) -> None:
        if not self._submit(self._answer_call, query):
            query.drop()

    def _answer_call(self, query: Any) -> None:
        with query:
            key = str(query.key_expr)
            try:
                if "*" in key:
                    raise InvalidNameError(f"a call names one node, not a pattern: {key!r}")
                _site, node, verb = keys.parse_node_key(key)
                payload = query.payload.to_bytes() if query.payload is not None else b"{}"
                reply = self._call(node, verb, codec.loads(payload, "a request"))
            except ParamddsError as exc:
                reply = codec.error_reply(exc)
            except Exception as exc:  # a bug here: the caller gets INTERNAL, never silence
                log.exception("forwarding %s failed", key)
                reply = codec.error_reply(InternalError(f"the gateway failed: {type(exc).__name__}: {exc}"))
            query.reply(key, reply, encoding=codec.ENCODING)

    def _call(self, node: str, verb: str, req: dict[str, Any]) -> bytes:
        timeout = _timeout_of(req)
        c = self.client
        try:
            if verb == "get":
                names = [str(n) for n in req.get("names", [])]
                g = c.get(node, names, with_descriptors=bool(req.get("with_descriptors")), timeout=timeout)
                return codec.get_reply(
                    keys.remote_name(self.site, g.node), g.revision, g.incarnation, g.results
                )
            if verb == "list":
                prefixes = [str(p) for p in req.get("prefixes", [])]
                r = c.list(node, prefixes, int(req.get("depth", 0)), timeout=timeout)
                return codec.list_reply(r.names, r.prefixes)
            if verb == "set":
                params = codec.parse_parameters(req.get("parameters"))
                expected = codec.parse_if_revision(req.get("if_revision"))
                who = str(req.get("who") or UNSAID)
                atomic = bool(req.get("atomic"))
                s = c.set(node, params, atomic=atomic, if_revision=expected, timeout=timeout, as_=who)
                return codec.set_reply(
                    keys.remote_name(self.site, s.node), s.revision, s.incarnation, s.results
                )
            if verb == "history":
                return self._history(node, history.query_in(req), timeout)
        except (KeyError, TypeError, ValueError) as exc:
            raise ParamddsError(f"a malformed {verb} request: {type(exc).__name__}: {exc}") from None
        raise InvalidNameError(f"unknown call {verb!r} (known: {', '.join(keys.VERBS)})")

    def _history(self, node: str, query: HistoryQuery, timeout: float) -> bytes:
        """One page of ``node``'s history, as the remote asker pages it (``after_seq``); its
        records named ``SITE/NODE``."""
        # one page: the client's history() walks every page, the asker here walks them itself
        kept, page = self.client.history_page(node, query, timeout=timeout)
        remote = keys.remote_name(self.site, node)
        records = tuple(r._replace(node=keys.remote_name(self.site, r.node)) for r in page.records)
        return history.history_reply(remote, replace(page, records=records), kept)

    # -- the end ----------------------------------------------------------------------------------------

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._active = False
            self._wake.notify_all()
        with self._role_lock:
            self._deactivate()
        _undeclare(self._gateway_sub)
        _undeclare(self._gateway_token)
        self._pool.shutdown(wait=False, cancel_futures=True)
        self.monitor.close()
        self.client.close()


def _timeout_of(req: dict[str, Any]) -> float:
    raw = req.get("timeout", DEFAULT_CALL_TIMEOUT)
    try:
        t = float(raw)
    except (TypeError, ValueError):
        raise ParamddsError(f"timeout must be a number of seconds, got {raw!r}") from None
    if not t > 0:
        raise ParamddsError(f"timeout must be positive, got {t}")
    # the caller's query waits `t`: answer a little before it gives up
    return min(MAX_CALL_TIMEOUT, max(0.05, t * 0.9))


def _election_key(token_id: str) -> tuple[int, str]:
    start, _, zid = token_id.partition("_")
    return (int(start), zid) if start.isdigit() else (2**63, token_id)


def _undeclare(entity: Any) -> None:
    try:
        entity.undeclare()
    except Exception:
        log.debug("undeclaring %r failed", entity, exc_info=True)


__all__ = ["BATCH", "Gateway"]
