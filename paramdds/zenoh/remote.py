"""The remote monitor: every site's nodes over Zenoh, named ``SITE/NODE``.

It has the shape of :class:`~paramdds.dds.monitor.ParameterMonitor` (a subclass, so the
CLI's verbs and the web console take either), with the DDS machinery replaced by Zenoh
subscriptions, queries and liveliness, through the protected interface of
:class:`~paramdds.dds.monitor.MonitorBase`. The remote client is
:func:`~paramdds.zenoh.client.RemoteParameterClient` (named here too).

The monitor subscribes to every node's ``state`` first, then asks each site's
  gateway for the current state of all its nodes (one query, answered from the
  gateway's current state, never from history), and keeps, per node, the publication
  with the highest ``seq`` of its gateway (a reply and a publication of one change
  may cross). A node is online while its gateway says so *and* its liveliness token
  is alive: a gateway killed, or an uplink cut, takes every node of its site offline
  within the Zenoh lease (:data:`~.config.LEASE_MS`); when a token comes back the node
  is asked for again (publications made meanwhile were lost), so nothing stale shows
  online.
"""

from __future__ import annotations

import fnmatch
import logging
import queue
import threading
import time
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import zenoh

from ..core.names import NodeFilter, is_node_glob
from ..dds.client import DEFAULT_TIMEOUT
from ..dds.monitor import EventCallback, EventKind, MonitorBase, MonitorEvent, NodeState, ParameterMonitor
from ..errors import ParamddsError
from . import codec, keys
from .client import REPLY_MARGIN
from .client import ROUTE_WAIT as ROUTE_WAIT  # the client's names, here too
from .client import RemoteParameterClient as RemoteParameterClient

log = logging.getLogger(__name__)

REFRESH_BATCH = 0.05  # seconds: nodes to ask for again are gathered this long, then asked per site
ASK_AGAIN = 3  # times a node whose state did not come, or did not decode, is asked for again
PARALLEL_QUERIES = 4  # state queries in flight at once (see _ask_states)
_ALL_ALIVE = keys.site_pattern("*", keys.ALIVE)
_ALL_GATEWAYS = f"{keys.PREFIX}/*/gateway/*"  # the gateways' tokens (not the active ones': one chunk more)


def sites_from_env(environ: Any = None) -> list[str] | None:
    """``PARAMDDS_ZENOH_SITES`` (``north,south``; globs allowed): the sites the CLI's monitor
    watches, site by site when they are exact names (an operator granted only those)."""
    import os

    text = (os.environ if environ is None else environ).get("PARAMDDS_ZENOH_SITES", "")
    sites = [s.strip() for s in text.split(",") if s.strip()]
    return sites or None


def remote_filter(patterns: Iterable[str]) -> NodeFilter:
    """``SITE/NODE`` names and globs over them (``s1/*``, ``*/robot1``, ``north*/*``): each
    names a site (or a glob of sites) and a node (InvalidNameError otherwise)."""
    checked: list[str] = []
    for raw in patterns:
        text = raw[1:] if raw.startswith("/") else raw
        if is_node_glob(text):
            site = text.split("/", 1)[0]
            if not is_node_glob(site):
                keys.check_site(site)
            checked.append(text)
        else:
            checked.append(keys.remote_name(*keys.split_remote(text)))
    return NodeFilter(checked)


def _is_delete(sample: Any) -> bool:
    return bool(sample.kind == zenoh.SampleKind.DELETE)


def _ask_states(
    session: Any, patterns: Sequence[str], timeout: float, bad: list[str] | None = None
) -> Iterator[codec.NodeStateMsg]:
    """Every node state the gateways answer for ``patterns``, all within ``timeout``, yielded
    as each query ends; the keys of replies that do not decode are added to ``bad``.

    Up to :data:`PARALLEL_QUERIES` queries are in flight at once, each bounded by what is
    left of ``timeout``. One query for every site at once was measured to fail: 30 sites x
    100 nodes (20 MB of replies) gave 605 of 3,000 states in 10 s and lost the session, on a
    Python router. One site after the other left a site slowed by loss all the time of the
    sites before it: at 30 % loss a site's nodes were once still missing after 10 s.
    Replies are only gathered in Zenoh's thread and decoded here, so a large answer never
    holds up the session."""
    deadline = time.monotonic() + timeout
    waiting = list(patterns)
    ended: queue.SimpleQueue[list[tuple[str, bytes]]] = queue.SimpleQueue()
    in_flight = 0
    while waiting or in_flight:
        while waiting and in_flight < PARALLEL_QUERIES:
            pattern = waiting.pop(0)
            left = deadline - time.monotonic()
            if left <= 0:
                log.warning("no time left to ask for the states of %s", pattern)
                continue
            _send_state_query(session, pattern, left, ended)
            in_flight += 1
        if not in_flight:
            return
        try:
            replies = ended.get(timeout=max(0.0, deadline - time.monotonic()) + REPLY_MARGIN)
        except queue.Empty:
            log.warning("%d state queries did not end within %g s", in_flight, timeout)
            return
        in_flight -= 1
        for key, payload in replies:
            try:
                yield codec.NodeStateMsg.decode(payload)
            except ParamddsError as exc:
                log.warning("ignoring a state from %s: %s", key, exc)
                if bad is not None:
                    bad.append(key)


def _send_state_query(
    session: Any, pattern: str, timeout: float, ended: queue.SimpleQueue[list[tuple[str, bytes]]]
) -> None:
    """Ask every gateway for the states of ``pattern``: (key, payload) of each reply go to
    ``ended`` once the query ends (all answered, or ``timeout``)."""
    replies: list[tuple[str, bytes]] = []

    def on_reply(reply: Any) -> None:
        sample = reply.ok
        if sample is not None:
            replies.append((str(sample.key_expr), sample.payload.to_bytes()))

    session.get(
        pattern,
        zenoh.handlers.Callback(on_reply, lambda: ended.put(replies)),
        timeout=timeout,
        target=zenoh.QueryTarget.ALL,
        consolidation=zenoh.QueryConsolidation(zenoh.ConsolidationMode.NONE),
    )


def _sites_of(session: Any, timeout: float) -> list[str]:
    """The sites whose gateway is up now (a gateway's liveliness token names its site)."""
    sites: set[str] = set()
    for reply in session.liveliness().get(_ALL_GATEWAYS, timeout=timeout):
        if reply.ok is not None:
            try:
                sites.add(keys.check_site(str(reply.ok.key_expr).split("/")[1]))
            except (ParamddsError, IndexError):
                continue
    return sorted(sites)


def _alive_of(session: Any, pattern: str, timeout: float) -> set[str]:
    """The remote names of the nodes whose liveliness token is alive now."""
    alive: set[str] = set()
    for reply in session.liveliness().get(pattern, timeout=timeout):
        if reply.ok is not None:
            try:
                site, node, _ = keys.parse_node_key(str(reply.ok.key_expr))
            except ParamddsError:
                continue
            alive.add(keys.remote_name(site, node))
    return alive


class RemoteParameterMonitor(ParameterMonitor):
    """Every node of every site (or of ``sites``, globs) over one Zenoh ``session``.

    ``nodes`` (``SITE/NODE`` names or globs, :func:`remote_filter`) keeps only those; when
    each names an exact site, only those sites are subscribed to (what an operator granted
    only some sites needs).

    ``snapshot()``, ``wait_until``, ``wait_complete``, ``wait_synced`` and the events
    (``added``, ``modified``, ``deleted``, ``online``, ``offline``, ``synced``) are those
    of :class:`~paramdds.dds.monitor.ParameterMonitor`; node names are ``SITE/NODE``.
    """

    def __init__(
        self,
        session: Any,
        *,
        sites: Iterable[str] | None = None,
        nodes: Iterable[str] | None = None,
        on_event: EventCallback | None = None,
        timeout: float = DEFAULT_TIMEOUT,
    ) -> None:
        # the monitor's state, waits and events (MonitorBase), fed from Zenoh instead of DDS
        MonitorBase.__init__(self, nodes=remote_filter(nodes) if nodes else None, on_event=on_event)
        self._sites = list(sites) if sites else None
        if self._sites is None and self._only is not None:  # nodes of exact sites: only those sites
            named = {p.split("/", 1)[0] for p in self._only.patterns()}
            if not any(is_node_glob(site) for site in named):
                self._sites = sorted(named)
        self._session = session
        self._timeout = timeout
        self._seen: dict[str, tuple[str, int]] = {}  # node -> (gateway, seq) of the state held
        self._reported: dict[str, bool] = {}  # node -> online as its gateway last said
        self._alive: set[str] = set()  # nodes whose liveliness token is alive
        self._gone: set[str] = set()  # nodes whose token the subscriber saw go (the first sync's get may lag)
        self._refresh_lock = threading.Lock()
        self._to_refresh: set[tuple[str, str]] = set()
        self._asked_again: dict[str, int] = {}  # node -> times asked again (see _ask_again)
        self._refresher: threading.Thread | None = None
        # an exact list of sites is asked for site by site (an operator whose certificate is granted
        # some sites may not even declare a subscriber on every site's keys); globs filter here
        exact = self._sites is not None and not any("*" in g or "?" in g for g in self._sites)
        self._scopes = [keys.check_site(site) for site in self._sites or ()] if exact else ["*"]
        self._entities = [
            entity
            for scope in self._scopes
            for entity in (
                session.declare_subscriber(keys.site_pattern(scope, keys.STATE), self._on_state),
                session.liveliness().declare_subscriber(
                    keys.site_pattern(scope, keys.ALIVE), self._on_alive, history=True
                ),
            )
        ]
        self._initial = threading.Thread(target=self._first_sync, name="paramdds-zenoh-sync", daemon=True)
        self._initial.start()

    def _wanted(self, name: str) -> bool:
        return super()._wanted(name) and self._wanted_site(name.split("/", 1)[0])

    def _wanted_site(self, site: str) -> bool:
        return self._sites is None or any(fnmatch.fnmatchcase(site, g) for g in self._sites)

    def _first_sync(self) -> None:
        bad: list[str] = []
        try:
            patterns: list[str] = []
            for scope in self._scopes:  # the tokens first, so that the states below show online exactly
                alive = _alive_of(self._session, keys.site_pattern(scope, keys.ALIVE), self._timeout)
                with self._cond:
                    self._alive.update(n for n in alive if self._wanted(n) and n not in self._gone)
                if scope == "*":  # a query per site (see _ask_states), the sites wanted of those up
                    known = {n.split("/", 1)[0] for n in alive} | set(_sites_of(self._session, self._timeout))
                    up = sorted(site for site in known if self._wanted_site(site))
                    patterns += [keys.site_pattern(site, keys.STATE) for site in up]
                else:
                    patterns.append(keys.site_pattern(scope, keys.STATE))
            for msg in _ask_states(self._session, patterns, self._timeout, bad):
                self._apply_state(msg)
        except Exception as exc:  # the session closed under us
            log.debug("the first state query failed: %s", exc)
        self._ask_again(bad)
        self._mark_synced()

    def _on_state(self, sample: Any) -> None:
        try:
            msg = codec.NodeStateMsg.decode(sample.payload.to_bytes())
        except ParamddsError as exc:
            log.warning("ignoring a state published on %s: %s", sample.key_expr, exc)
            return
        self._apply_state(msg)

    def _on_alive(self, sample: Any) -> None:
        try:
            site, node, _ = keys.parse_node_key(str(sample.key_expr))
        except ParamddsError:
            return
        name = keys.remote_name(site, node)
        if not self._wanted(name):
            return
        events: list[MonitorEvent] = []
        came_back = False
        with self._cond:
            if _is_delete(sample):
                self._alive.discard(name)
                self._gone.add(name)
            else:
                came_back = name in self._gone
                self._alive.add(name)
                self._gone.discard(name)
            state = self._states.get(name)
            if state is not None:
                event = self._set_online(state, self._reported.get(name, False) and name in self._alive)
                if event is not None:
                    events.append(event)
            self._cond.notify_all()
        self._emit(events)
        if not _is_delete(sample) and (self.synced or came_back):
            # back (a gateway took over, an uplink came back, a session dropped by loss): what was
            # published meanwhile is lost, and so is a first query that was in flight (before the
            # first sync is done, a token seen for the first time is in its query anyway)
            self._refresh(site, node)

    def _refresh(self, site: str, node: str) -> None:
        """Ask for ``node``'s whole state again, soon (one thread asks for all, a query per site)."""
        with self._refresh_lock:
            if self._closed:
                return
            self._to_refresh.add((site, node))
            if self._refresher is None or not self._refresher.is_alive():
                self._refresher = threading.Thread(
                    target=self._refresh_loop, name="paramdds-zenoh-refresh", daemon=True
                )
                self._refresher.start()

    def _refresh_loop(self) -> None:
        while True:
            time.sleep(REFRESH_BATCH)  # a site coming back announces its nodes in a burst
            with self._refresh_lock:
                wanted, self._to_refresh = self._to_refresh, set()
                if not wanted or self._closed:
                    self._refresher = None
                    return
            by_site: dict[str, list[str]] = {}
            for site, node in wanted:
                by_site.setdefault(site, []).append(node)
            asked = [
                keys.node_key(site, site_nodes[0], keys.STATE)
                if len(site_nodes) == 1
                else keys.site_pattern(site, keys.STATE)
                for site, site_nodes in by_site.items()
            ]
            bad: list[str] = []
            try:
                for msg in _ask_states(self._session, asked, self._timeout, bad):
                    self._apply_state(msg)
            except Exception as exc:  # the session closed under us
                log.debug("refreshing %s failed: %s", asked, exc)
            self._ask_again(bad)

    def _ask_again(self, bad: list[str]) -> None:
        """Ask again (up to :data:`ASK_AGAIN` times a node) for the states whose reply did not
        decode (seen in a 30-site bench: a reply with bytes that were not its JSON), and for
        the nodes whose token is alive but whose state did not come (the query's timeout ended
        before every reply of a large fleet had arrived)."""
        asked: set[tuple[str, str]] = set()
        for key in bad:
            try:
                site, node, _ = keys.parse_node_key(key)
            except ParamddsError:
                continue
            asked.add((site, node))
        with self._cond:
            missing = [n for n in self._alive if n not in self._states]
        asked.update(keys.split_remote(n) for n in missing)
        for site, node in asked:
            name = keys.remote_name(site, node)
            with self._refresh_lock:
                tries = self._asked_again[name] = self._asked_again.get(name, 0) + 1
            if tries <= ASK_AGAIN:
                self._refresh(site, node)

    def _apply_state(self, msg: codec.NodeStateMsg) -> None:
        name = keys.remote_name(msg.site, msg.node)
        if not self._wanted(name):
            return
        events: list[MonitorEvent] = []
        with self._cond:
            self._touch()
            seen = self._seen.get(name)
            if seen is not None and seen[0] == msg.gateway and msg.seq <= seen[1]:
                return  # this state or a newer one is held already
            state = self._states.get(name)
            if msg.kind == "delta":
                if state is None or seen != (msg.gateway, msg.base):
                    gap = True  # not the state this change follows: ask for the whole one
                else:
                    gap = False
                    merged = {n: e for n, e in state.parameters.items() if n not in msg.deleted}
                    merged.update(msg.parameters)
                    msg.parameters, msg.kind = merged, "state"
                if gap:
                    self._refresh(msg.site, msg.node)
                    return
            self._seen[name] = (msg.gateway, msg.seq)
            if state is None:
                state = self._states[name] = NodeState(name)
            old = state.parameters
            stamp = time.time()
            if self._has_callbacks:
                for pname, (value, descriptor) in msg.parameters.items():
                    before = old.get(pname)
                    if before is None:
                        kind = EventKind.ADDED
                    elif not before[0].same_as(value) or before[1] != descriptor:
                        kind = EventKind.MODIFIED
                    else:
                        continue
                    events.append(
                        MonitorEvent(
                            kind, name, pname, value, descriptor, msg.revision, stamp, msg.incarnation
                        )
                    )
                for pname, (value, descriptor) in old.items():
                    if pname not in msg.parameters:
                        events.append(
                            MonitorEvent(
                                EventKind.DELETED,
                                name,
                                pname,
                                value,
                                descriptor,
                                msg.revision,
                                stamp,
                                msg.incarnation,
                            )
                        )
            state.parameters = dict(msg.parameters)
            state.host, state.pid = msg.host, msg.pid
            state.revision, state.announced = msg.revision, msg.announced
            state.incarnation, state.origin = msg.incarnation, msg.origin
            self._reported[name] = msg.online
            self._add(events, self._status_event(state, msg.status))
            self._add(events, self._set_online(state, msg.online and name in self._alive))
            self._cond.notify_all()
        with self._refresh_lock:
            self._asked_again.pop(name, None)  # held now: a later loss gets its own tries
        self._emit(events)

    def close(self) -> None:
        MonitorBase.close(self)  # not ParameterMonitor's: no DDS reader here
        for entity in self._entities:
            try:
                entity.undeclare()
            except Exception:
                log.debug("undeclaring %r failed", entity, exc_info=True)
