"""The remote monitor: every site's nodes over Zenoh, named ``SITE/NODE``.

:class:`RemoteParameterMonitor` is a :class:`~paramdds.dds.monitor.ParameterMonitor`
fed by a :class:`ZenohStateFeed` instead of a DDS reader, so the CLI's verbs and the web
console take it as they take the DDS one. The feed:

* follows the gateways' tokens, and each site on its own (the sites named, or those
  whose gateway is up, now or later): subscribes to its nodes' ``state`` and liveliness
  tokens first, then asks its gateway for the current state of all its nodes (one query
  per site, every site's at once, answered from the gateway's current state, never from
  history), and marks the monitor synced;
* applies each state and token by the rules of :mod:`.monitor_rules` (the newest state
  of a node's gateway is held; a node is online while its gateway says so *and* its
  token is alive *and* a gateway of its site is up): a gateway killed, or an uplink cut or
  dropped by loss, shows every node of its site ``stale`` within the Zenoh lease
  (:data:`~.config.LEASE_MS`) and :data:`~.monitor_rules.SITE_GRACE`, told once as a
  ``site_status`` event; a gateway back within :data:`~.monitor_rules.SITE_HOLD` seconds
  makes them fresh again (another ``site_status``), else the site goes offline, told once
  as a ``site_offline`` event (and ``site_online`` when a gateway is back);
* asks for a node's whole state again when its token comes back (publications made
  meanwhile were lost, so nothing stale shows as current), and every node of a site when a
  gateway of it is back after none (held or offline), when a delta does not follow the
  state held, and (a few times) when a state did not come or did not decode.
"""

from __future__ import annotations

import fnmatch
import logging
import threading
import time
from collections.abc import Iterable
from typing import Any

import zenoh

from ..core.names import NodeFilter, is_node_glob
from ..core.state_book import StateBook
from ..dds.client import DEFAULT_TIMEOUT
from ..dds.monitor import EventCallback, ParameterMonitor
from ..errors import ParamddsError
from . import codec, keys
from .completeness import Lack, SiteLedger
from .monitor_rules import GAP, HELD, SITE_GRACE, Confirmed, RemoteStates
from .states import ROUTE_WAIT, ask_states, gateways_of, payload_summary, site_active

log = logging.getLogger(__name__)

REFRESH_BATCH = 0.05  # seconds: nodes to ask for again are gathered this long, then asked per site
CONFIRM_WAIT = 2.0  # seconds the router is given to say which tokens of a site are alive
CONFIRM_ASKS = 3  # liveliness gets per confirmation: a token is gone only if none of them holds it
CONFIRM_PAUSE = 0.1  # seconds between them
ASK_AGAIN = 3  # times a node whose state did not come, or did not decode, is asked for again


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


class RemoteParameterMonitor(ParameterMonitor):
    """Every node of every site (or of ``sites``, globs) over one Zenoh ``session``.

    ``nodes`` (``SITE/NODE`` names or globs, :func:`remote_filter`) keeps only those; when
    each names an exact site, only those sites are subscribed to (what an operator granted
    only some sites needs).

    ``snapshot()``, ``wait_until``, ``wait_complete``, ``wait_synced`` and the events
    (``added``, ``modified``, ``deleted``, ``online``, ``offline``, ``status``, ``synced``)
    are those of :class:`~paramdds.dds.monitor.ParameterMonitor`; node names are
    ``SITE/NODE``; a whole site's are ``site_status``, ``site_offline`` and ``site_online``.
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
        only = remote_filter(nodes) if nodes else None
        feed = ZenohStateFeed(session, sites=sites, nodes=only, timeout=timeout)
        super().__init__(feed, nodes=only, on_event=on_event)
        self._remote_feed = feed

    def missing_sites(self) -> dict[str, Lack]:
        """The known sites this monitor lacks (:mod:`.completeness`): site -> why; empty when
        every site known answered in full and is still up (``*``: no site is known at all)."""
        return self._remote_feed.missing_sites()


class ZenohStateFeed:
    """A :class:`~paramdds.core.state_book.StateFeed` from the gateways of every site (or of
    ``sites``, globs; or of the exact sites ``nodes`` names) over one Zenoh ``session``;
    each query bounded by ``timeout``."""

    def __init__(
        self,
        session: Any,
        *,
        sites: Iterable[str] | None = None,
        nodes: NodeFilter | None = None,
        timeout: float = DEFAULT_TIMEOUT,
    ) -> None:
        self._sites = list(sites) if sites else None
        if self._sites is None and nodes is not None:  # nodes of exact sites: only those sites
            named = {p.split("/", 1)[0] for p in nodes.patterns()}
            if not any(is_node_glob(site) for site in named):
                self._sites = sorted(named)
        self._session = session
        self._timeout = timeout
        self._book: StateBook | None = None
        self._states = RemoteStates()  # changed only in the book's updates (under its lock)
        self._refresh_lock = threading.Lock()
        self._to_refresh: set[tuple[str, str]] = set()
        self._asked_again: dict[str, int] = {}  # node -> times asked again (see _ask_again)
        self._refresher: threading.Thread | None = None
        self._suspects: set[str] = set()  # sites a token of which went, to ask the router about
        self._verifying = False  # a confirmation of the tokens gone is due (see _confirm_later)
        self._expiring: set[str] = set()  # sites held, whose end of hold is due (see _hold_later)
        # sites whose first gateway came before the first sync chose its sites (None: chosen)
        self._early: set[str] | None = set()
        # an exact list of sites is asked for site by site (an operator whose certificate is granted
        # some sites may not even declare a subscriber on every site's keys); globs filter here
        exact = self._sites is not None and not any("*" in g or "?" in g for g in self._sites)
        self._scopes = [keys.check_site(site) for site in self._sites or ()] if exact else ["*"]
        # the sites known (the exact ones named, those seen), and those that answered
        self._ledger = SiteLedger(keys.check_site(s) for s in self._sites or () if not is_node_glob(s))
        self._exact = exact
        self._followed: set[str] = set()  # the sites whose states and tokens are subscribed to
        self._entities: list[Any] = []

    @property
    def _sink(self) -> StateBook:
        if self._book is None:
            raise RuntimeError("the Zenoh feed was not started")
        return self._book

    def start(self, book: StateBook) -> None:
        self._book = book
        session = self._session
        # the gateways' tokens (a site is offline when its last gateway's goes; a site whose first
        # gateway comes is followed), without history: a liveliness get on this session (the first
        # sync's, a client's) crossing a liveliness subscriber with history on the same keys returned
        # nothing (Zenoh 1.10). Every named certificate may follow them (:mod:`.acl`).
        self._entities = [
            session.liveliness().declare_subscriber(keys.gateways_pattern(scope), self._on_gateway)
            for scope in self._scopes
        ]
        if self._exact:
            for site in self._scopes:
                self._subscribe(site)
        threading.Thread(target=self._first_sync, name="paramdds-zenoh-sync", daemon=True).start()

    def _subscribe(self, site: str) -> bool:
        """Follow ``site``'s states and node tokens (once; False when followed already). A
        subscriber per site, never one over every site: a router's access control grants a
        certificate some sites' keys, and refuses a pattern over all of them."""
        with self._refresh_lock:
            if site in self._followed or self._sink.closed:
                return False
            self._followed.add(site)
        session = self._session
        entities = [
            session.declare_subscriber(keys.site_pattern(site, keys.STATE), self._on_state),
            session.liveliness().declare_subscriber(
                keys.site_pattern(site, keys.ALIVE), self._on_alive, history=True
            ),
        ]
        with self._refresh_lock:
            self._entities += entities
        return True

    def _follow_new(self, site: str) -> None:
        """Follow a site whose first gateway came after the first sync chose its sites, and ask
        for its states."""
        try:
            if self._subscribe(site):
                self._sync_sites([site], [])
        except Exception as exc:  # the session closed under us
            log.debug("following site %s failed: %s", site, exc)

    def close(self) -> None:
        with self._refresh_lock:
            entities, self._entities = self._entities, []
        for entity in entities:
            try:
                entity.undeclare()
            except Exception:
                log.debug("undeclaring %r failed", entity, exc_info=True)

    def _wanted(self, name: str) -> bool:
        return self._sink.wanted(name) and self._wanted_site(name.split("/", 1)[0])

    def _wanted_site(self, site: str) -> bool:
        return self._sites is None or any(fnmatch.fnmatchcase(site, g) for g in self._sites)

    def missing_sites(self) -> dict[str, Lack]:
        with self._sink.update() as change:
            lacking = {n.split("/", 1)[0] for n in self._states.missing(change)}
            down = self._states.sites_down()
        return self._ledger.missing(lacking, down)

    def _first_sync(self) -> None:
        book = self._sink
        bad: list[str] = []
        try:
            if self._exact:
                sites = list(self._scopes)
            else:  # the sites wanted of those whose gateway is up
                found = gateways_of(self._session, self._timeout)
                sites = sorted(s for s in found if self._wanted_site(s))
                for site in sites:
                    self._subscribe(site)
            early = self._chosen(set(sites))
            self._sync_sites(sites, bad)
            for site in sorted(early):  # a gateway seen while the sites were chosen, of another site
                self._site_up(site)
        except Exception as exc:  # the session closed under us
            log.debug("the first state query failed: %s", exc)
        self._ask_again(bad)
        book.mark_synced()

    def _sync_sites(self, sites: list[str], bad: list[str]) -> None:
        """The node tokens of ``sites`` first (so that the states show online exactly), whether
        their gateways are up, then their states: a query per site (see ask_states)."""
        book = self._sink
        for site in sites:
            alive = _alive_of(self._session, keys.site_pattern(site, keys.ALIVE), self._timeout)
            with book.update():
                self._states.tokens_found(n for n in alive if self._wanted(n))
            found = gateways_of(self._session, self._timeout, site)
            with book.update():
                self._states.gateways_found(found)
            self._ledger.gateways_up(list(found))
        self._ask_sites([keys.site_pattern(site, keys.STATE) for site in sites], bad)

    def _ask_sites(self, patterns: list[str], bad: list[str]) -> None:
        """Ask for the states of ``patterns``; a site's pattern whose query ended in time
        counts as the site answered, unless no gateway of it serves this client (its
        certificate is not granted the site: :meth:`_refused`)."""
        answered: set[str] = set()
        replied: set[str] = set()
        for msg in ask_states(self._session, patterns, self._timeout, bad, answered):
            replied.add(msg.site)
            self._apply_state(msg)
        by_pattern = {keys.site_pattern(s, keys.STATE): s for s in self._ledger.known()}
        sites = [by_pattern[p] for p in answered if p in by_pattern]
        refused = [s for s in sites if s not in replied and self._ledger.is_up(s) and self._refused(s)]
        self._ledger.refused(refused)
        self._ledger.answered(s for s in sites if s not in refused)

    def _refused(self, site: str) -> bool:
        """Whether ``site`` has an active gateway but none serves its states to this client: the
        router's access control refuses this certificate the site (asked only of a site whose
        state query came back empty)."""
        querier = self._session.declare_querier(keys.site_pattern(site, keys.STATE))
        try:
            until = time.monotonic() + ROUTE_WAIT
            while not querier.matching_status.matching:
                if time.monotonic() >= until:
                    return site_active(self._session, site)
                time.sleep(0.01)
            return False
        finally:
            querier.undeclare()

    def _on_state(self, sample: Any) -> None:
        key, payload = str(sample.key_expr), sample.payload.to_bytes()
        try:
            msg = codec.NodeStateMsg.decode(payload)
        except ParamddsError as exc:  # the change it carried is lost: ask for the node, as for a reply
            log.warning("ignoring a state published on %s (%s): %s", key, payload_summary(payload), exc)
            self._ask_again([key], missing=False)
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
        book = self._sink
        with book.update() as change:
            came_back = self._states.token(change, name, not _is_delete(sample))
        if _is_delete(sample):
            self._confirm_later(site)
        elif book.synced or came_back:
            # back (a gateway took over, an uplink came back, a session dropped by loss): what was
            # published meanwhile is lost, and so is a first query that was in flight (before the
            # first sync is done, a token seen for the first time is in its query anyway)
            self._refresh(site, node)

    def _on_gateway(self, sample: Any) -> None:
        key = str(sample.key_expr)
        try:
            gateway, active_since = keys.parse_gateway_key(key)
            site = keys.check_site(key.split("/")[1])
        except (ParamddsError, IndexError):
            return
        if active_since is not None or not self._wanted_site(site):
            return
        if _is_delete(sample):  # believed once the router confirms it
            with self._sink.update():
                self._states.gateway_went(site, gateway)
            self._confirm_later(site)
            return
        self._ledger.gateways_up([site])
        with self._sink.update() as change:
            if not self._states.gateway(change, site, gateway, True):
                return
            unsure = self._states.unsure(site)
        self._site_back(site)
        if unsure:  # back from its hold before some of its nodes' tokens
            self._confirm_later(site)

    def _site_back(self, site: str) -> None:
        # a site's first gateway, or one back (what it published meanwhile is lost): ask for the
        # site's states, unless the first sync has not chosen its sites yet (it asks them after)
        with self._refresh_lock:
            if self._early is not None:
                self._early.add(site)
                return
        self._site_up(site)

    def _site_up(self, site: str) -> None:
        """A gateway of ``site`` is up after none: a site followed has its states asked for
        again; one not followed yet is followed, and asked for, on a thread of its own."""
        with self._refresh_lock:
            followed = site in self._followed
        if followed:
            self._refresh(site, "")
        else:
            name = "paramdds-zenoh-site"
            threading.Thread(target=self._follow_new, args=(site,), name=name, daemon=True).start()

    def _chosen(self, asked: set[str]) -> set[str]:
        """The first sync asks ``asked``: from now on a site's first gateway asks for the site's
        states. The sites whose first gateway came meanwhile, and that the first sync does not
        ask, are returned (to be asked)."""
        with self._refresh_lock:
            early, self._early = self._early or set(), None
            return early - asked

    def _confirm_later(self, site: str) -> None:
        """Ask the router :data:`SITE_GRACE` seconds on which tokens of ``site`` (and of every
        other site a token of which went meanwhile) are still alive (:meth:`_confirm`)."""
        with self._refresh_lock:
            self._suspects.add(site)
            if self._verifying or self._sink.closed:
                return
            self._verifying = True
        timer = threading.Timer(SITE_GRACE, self._confirm)
        timer.daemon = True
        timer.start()

    def _confirm(self) -> None:
        """The tokens alive now of the sites a token of which went, from the router (a
        liveliness get each), decide what is gone (:meth:`_confirm_site`)."""
        with self._refresh_lock:
            self._verifying = False
            sites, self._suspects = sorted(self._suspects), set()
        for site in sites:
            if not self._confirm_site(site):
                return

    def _confirm_site(self, site: str) -> bool:
        """Ask the router which tokens of ``site`` are alive and apply it
        (:meth:`RemoteStates.confirm`); False when the session closed under us."""
        book = self._sink
        with book.update():
            mark = self._states.mark()
        try:
            gateways, alive = self._held(site)
        except Exception as exc:  # the session closed under us
            log.debug("confirming the tokens of site %s failed: %s", site, exc)
            return False
        now = time.monotonic()
        with book.update() as change:
            done: Confirmed = self._states.confirm(change, site, mark, gateways, alive, now)
        if done.up:
            self._site_back(site)
        for name in done.back:
            self._refresh(*keys.split_remote(name))
        if done.again:
            self._confirm_later(site)
        if done.hold_until is not None:
            self._hold_later(site, done.hold_until - now)
        return True

    def _hold_later(self, site: str, delay: float) -> None:
        """Ask the router about ``site`` again once its hold is over (``delay`` seconds): with
        no gateway back, that makes it ``site_offline``."""
        with self._refresh_lock:
            if site in self._expiring or self._sink.closed:
                return
            self._expiring.add(site)
        timer = threading.Timer(max(delay, 0.0), self._hold_over, (site,))
        timer.daemon = True
        timer.start()

    def _hold_over(self, site: str) -> None:
        with self._refresh_lock:
            self._expiring.discard(site)
        self._confirm_site(site)

    def _held(self, site: str) -> tuple[set[str], set[str]]:
        """The gateways and the nodes of ``site`` whose tokens the router holds: those in any of
        :data:`CONFIRM_ASKS` liveliness gets. One get is not enough: under churn a get now and
        then ends at once with no reply while the router holds every token (5 of 86 in a soak,
        a get a millisecond earlier answering all 60), and all of a healthy site would go."""
        gateways: set[str] = set()
        alive: set[str] = set()
        pattern = keys.site_pattern(site, keys.ALIVE)
        for ask in range(CONFIRM_ASKS):
            if ask:
                time.sleep(CONFIRM_PAUSE)
            gateways |= gateways_of(self._session, CONFIRM_WAIT, site).get(site, set())
            alive |= {n for n in _alive_of(self._session, pattern, CONFIRM_WAIT) if self._wanted(n)}
        return gateways, alive

    def _refresh(self, site: str, node: str) -> None:
        """Ask for ``node``'s whole state again (``""``: every node of ``site``), soon (one
        thread asks for all, a query per site)."""
        with self._refresh_lock:
            if self._sink.closed:
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
                if not wanted or self._sink.closed:
                    self._refresher = None
                    return
            by_site: dict[str, list[str]] = {}
            for site, node in wanted:
                by_site.setdefault(site, []).append(node)
            asked = [
                keys.node_key(site, site_nodes[0], keys.STATE)
                if len(site_nodes) == 1 and site_nodes[0]  # "": the whole site
                else keys.site_pattern(site, keys.STATE)
                for site, site_nodes in by_site.items()
            ]
            bad: list[str] = []
            try:
                self._ask_sites(asked, bad)
            except Exception as exc:  # the session closed under us
                log.debug("refreshing %s failed: %s", asked, exc)
            self._ask_again(bad)

    def _ask_again(self, bad: list[str], *, missing: bool = True) -> None:
        """Ask again (up to :data:`ASK_AGAIN` times a node) for the states whose reply or
        publication did not decode (the keys ``bad``: a Zenoh link closed while a batch was
        half written splices the next batch's framing into a payload, docs/zenoh.md "Limits"),
        and, with ``missing``, for the nodes whose token is alive but whose state did not come
        (the query's timeout ended before every reply of a large fleet had arrived)."""
        asked: set[tuple[str, str]] = set()
        for key in bad:
            try:
                site, node, _ = keys.parse_node_key(key)
            except ParamddsError:
                continue
            if self._wanted(keys.remote_name(site, node)):
                asked.add((site, node))
        if missing:
            with self._sink.update() as change:
                lacking = self._states.missing(change)
            asked.update(keys.split_remote(n) for n in lacking)
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
        book = self._sink
        with book.update() as change:
            outcome = self._states.apply(book, change, name, msg)
            if outcome is GAP:  # not the state this change follows: ask for the whole one
                self._refresh(msg.site, msg.node)
        if outcome is HELD:
            with self._refresh_lock:
                self._asked_again.pop(name, None)  # held now: a later loss gets its own tries


def _is_delete(sample: Any) -> bool:
    return bool(sample.kind == zenoh.SampleKind.DELETE)


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
