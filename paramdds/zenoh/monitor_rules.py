"""The remote monitor's rules: what a gateway's node state and a liveliness token change.

Pure: :class:`RemoteStates` takes decoded states (:class:`~.codec.NodeStateMsg`) and
tokens seen or gone, and changes the monitor's book in the update it is given; asking
Zenoh for anything is :mod:`.monitor`'s. Its rules:

* per node, only the state with the highest ``seq`` of its gateway is held (a reply and
  a publication of one change may cross); a ``delta`` applies only on top of the state
  it follows (else the whole state must be asked for: :data:`GAP`);
* holding a state is an event per parameter added, modified or deleted since the state
  held before (none when nothing changed); each parameter's last change (blame) is the
  state's, carried by its ``added`` / ``modified`` event;
* a node is online while its gateway says so *and* its liveliness token is alive *and*
  its site has a gateway whose token is alive;
* a site whose every gateway's token went (the gateway killed, or its uplink cut or its
  session dropped by loss: the router drops the session and every token of it) is *held*
  for :data:`SITE_HOLD` seconds: one ``site_status`` event with status ``stale``, its
  online nodes stay online with status ``stale`` (their values the copy held; their
  ``status`` events marked ``by_site``). A gateway of it back within the hold is one
  ``site_status`` event with no status, its nodes' statuses back as their gateway said
  (marked ``by_site`` too), and no node goes offline or online: a node whose token is not
  back yet is left to a confirmation. A hold that ends with no gateway back is one
  ``site_offline`` event, its nodes' ``offline`` events marked ``by_site``; a gateway of it
  coming back after that is one ``site_online``, and its nodes' ``online`` events are
  marked so too (a log shows the site's line, not one per node);
* a token's going is believed once the router confirms it (:meth:`RemoteStates.confirm`,
  with what a liveliness get found :data:`SITE_GRACE` seconds later): the router drops a
  session's tokens in no set order, so a node whose token went first is shown online
  until then, and its site's ``site_offline`` comes with it if the site's gateways went
  too. The get is also the truth where the subscriber was wrong: with Zenoh 1.10 a
  session dropped by the router (an uplink cut) made a client's liveliness subscriber
  report a token of *another* site gone while the router still held it, and the dropped
  session's own gateway token never reported gone. But a get can miss tokens the router
  holds too (under churn every get of one confirmation ended at once with no reply, 1 of
  720 confirmations in an hour's soak): a node whose token was never seen going and that a
  confirmation does not find is *doubted*, still online, and confirmed again until
  :data:`DOUBT_FOR` seconds have passed; gone only if the router still lacks it then.

Every method runs inside an update of the book (its lock held), which guards this
object too.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import replace
from enum import Enum
from typing import NamedTuple

from ..core.descriptors import ParameterDescriptor
from ..core.monitor_events import Blame, EventKind, MonitorEvent, NodeState
from ..core.results import LastChange
from ..core.state_book import BookUpdate, StateBook
from ..core.values import ParameterValue
from ..dds.filters import STALE
from .codec import NodeStateMsg

Table = dict[str, tuple[ParameterValue, ParameterDescriptor]]  # a node's parameters by name
SITE_GRACE = 0.25  # seconds after a token went until the router is asked what is still alive
# seconds a site whose every gateway went shows ``stale`` before it is ``site_offline``: of the
# gateway sessions dropped by 30 % loss on their uplink (a TCP stream stalled past the lease), 15 of
# 17 were back within 0.36-4.85 s, the others after 12 s (docs/zenoh.md, "Presence under loss")
SITE_HOLD = 5.0
DOUBT_FOR = 1.0  # seconds a node not seen going, missing from a get, is asked about again before it goes


class Outcome(Enum):
    HELD = "held"  # the state is the node's now
    OLD = "old"  # this state or a newer one is held already: nothing changed
    GAP = "gap"  # a delta that does not follow the state held: ask for the whole state


HELD, OLD, GAP = Outcome.HELD, Outcome.OLD, Outcome.GAP


class Confirmed(NamedTuple):
    """What a confirmation (:meth:`RemoteStates.confirm`) leaves the feed to do."""

    up: bool  # the site has a gateway again after none: ask for its states
    back: list[str]  # the nodes whose token is back: ask for each again
    again: bool  # nodes of a site back from its hold have no token yet: confirm them later
    hold_until: float | None  # the site is held until then: confirm it again at that time


class RemoteStates:
    """What the remote monitor knows besides the book: which state each node's gateway sent
    last, whether that gateway says the node is online, and whose tokens are alive."""

    def __init__(self, hold: float = SITE_HOLD) -> None:
        self._hold = hold  # seconds a site whose every gateway went is held (0: site_offline at once)
        self._seen: dict[str, tuple[str, int]] = {}  # node -> (gateway, seq) of the state held
        self._reported: dict[str, bool] = {}  # node -> online as its gateway last said
        self._status: dict[str, str | None] = {}  # node -> status as its gateway last said
        self._alive: set[str] = set()  # nodes whose liveliness token is alive
        self._gone: set[str] = set()  # nodes whose token was seen going (a first get may lag)
        self._gateways: dict[str, set[str]] = {}  # site -> its gateways whose token is alive
        self._gw_gone: set[tuple[str, str]] = set()  # (site, gateway) seen going before being seen
        self._held: dict[str, float] = {}  # site -> until when it is held (its every gateway went)
        self._down: set[str] = set()  # sites seen up whose every gateway went, and stayed away
        self._leaving: set[str] = set()  # nodes whose token went, their site's gateway up: unconfirmed
        self._doubted: dict[str, float] = {}  # node not seen going that a get missed -> since when
        self._dropped: set[str] = set()  # nodes taken offline with their site, not online since
        self._staled: set[str] = set()  # nodes shown stale by their site's hold
        self._tick = 0  # counts the tokens seen coming and going
        self._ticks: dict[object, int] = {}  # node or (site, gateway) -> tick of its last token event

    def tokens_found(self, names: Iterable[str]) -> None:
        """The tokens a liveliness get found alive (those seen going since are not)."""
        self._alive.update(n for n in names if n not in self._gone)

    def token(self, change: BookUpdate, name: str, alive: bool) -> bool:
        """A node's token came (``alive``) or went; True when it came back after going. A token
        that goes while its site's gateway is up leaves the node online until :meth:`confirm`."""
        self._touch(name)
        self._doubted.pop(name, None)  # seen coming or going: its own event decides
        came_back = False
        if alive:
            came_back = name in self._gone
            self._alive.add(name)
            self._gone.discard(name)
            self._leaving.discard(name)
        else:
            self._alive.discard(name)
            self._gone.add(name)
            if self._gateways.get(_site(name)):
                self._leaving.add(name)
        self._show(change, name)
        return came_back

    def gateway_went(self, site: str, gateway: str) -> None:
        """A gateway's token was reported gone: believed at :meth:`confirm` (never at once)."""
        self._touch((site, gateway))

    def _touch(self, key: object) -> None:
        self._tick += 1
        self._ticks[key] = self._tick

    def mark(self) -> int:
        """Where the token events are now: take it before asking the router (see :meth:`confirm`)."""
        return self._tick

    def confirm(
        self, change: BookUpdate, site: str, mark: int, gateways: set[str], alive: set[str], now: float
    ) -> Confirmed:
        """What the router held of ``site`` when asked after ``mark``: the ``gateways`` whose
        token is alive and the nodes ``alive``; ``now`` on the feed's clock (seconds, monotonic).
        It decides every token of the site not seen coming or going since ``mark`` (those are
        their own events'): gateways first (the site held when none is left, ``site_offline``
        once its hold is over with none back), then nodes."""

        def settled(key: object) -> bool:
            return self._ticks.get(key, 0) <= mark

        known = self._gateways.setdefault(site, set())
        for gone in sorted(g for g in known - gateways if settled((site, g))):
            self.gateway(change, site, gone, False, now)
        up = False
        for came in sorted(g for g in gateways - known if settled((site, g))):
            up = self.gateway(change, site, came, True) or up
        until = self._held.get(site)
        if until is not None and now >= until:
            self._offline(change, site)
            until = None
        back: list[str] = []
        ours = {n for n in (*self._alive, *self._leaving, *alive) if _site(n) == site and settled(n)}
        for name in sorted(ours):
            held = name in alive
            if held or name not in self._alive or name in self._leaving:
                self._doubted.pop(name, None)
            elif now - self._doubted.setdefault(name, now) < DOUBT_FOR:
                continue  # never seen going: asked about again (unsure) before it is believed gone
            else:
                del self._doubted[name]
            if held and name not in self._alive and name not in self._leaving:
                back.append(name)
            self._leaving.discard(name)
            if held:
                self._alive.add(name)
                self._gone.discard(name)
            else:
                self._alive.discard(name)
                self._gone.add(name)
            self._show(change, name)
        return Confirmed(up, back, self.unsure(site), until)

    def unsure(self, site: str) -> bool:
        """Whether a node of ``site`` is shown online with its token gone, unconfirmed (a site
        back from its hold before its nodes' tokens), or doubted: to confirm soon."""
        return any(_site(n) == site for n in (*self._leaving, *self._doubted))

    def gateways_found(self, found: dict[str, set[str]]) -> None:
        """The gateways' tokens a liveliness get found alive, by site (those seen going since
        are not)."""
        for site, gateways in found.items():
            alive = {g for g in gateways if (site, g) not in self._gw_gone}
            self._gateways.setdefault(site, set()).update(alive)

    def gateway(self, change: BookUpdate, site: str, gateway: str, alive: bool, now: float = 0.0) -> bool:
        """A gateway's token of ``site`` came (``alive``) or went (at ``now``, the feed's clock):
        the site held when the last one went; a gateway back ends the hold (or, after the
        site's ``site_offline``, is its ``site_online``). True when the site has a gateway
        again after none (the first one seen, or one back)."""
        self._touch((site, gateway))
        gateways = self._gateways.setdefault(site, set())
        if not alive:
            if gateway not in gateways:
                self._gw_gone.add((site, gateway))  # a get that lags must not revive it
                return False
            gateways.discard(gateway)
            if gateways or site in self._held or site in self._down:
                return False
            if self._hold <= 0:
                self._offline(change, site)
                return False
            self._held[site] = now + self._hold
            change.emit(MonitorEvent(EventKind.SITE_STATUS, stamp=time.time(), site=site, status=STALE))
            for name in self._nodes_of(site):
                self._leaving.discard(name)
                self._show(change, name)
            return False
        first = not gateways
        gateways.add(gateway)
        if site in self._held:  # back within the hold: its nodes stay as they are, fresh again
            del self._held[site]
            change.emit(MonitorEvent(EventKind.SITE_STATUS, stamp=time.time(), site=site))
            for name in self._nodes_of(site):
                state = change.get(name)
                if state is not None and state.online and name not in self._alive:
                    self._leaving.add(name)  # its token is not back yet: confirmed later
                    self._touch(name)
                self._show(change, name)
            return True
        if site not in self._down:
            return first
        self._down.discard(site)
        change.emit(MonitorEvent(EventKind.SITE_ONLINE, stamp=time.time(), site=site))
        for name in self._nodes_of(site):
            self._show(change, name)
        return True

    def _offline(self, change: BookUpdate, site: str) -> None:
        """``site`` has had no gateway for its hold: its ``site_offline``, its nodes offline."""
        self._held.pop(site, None)
        self._down.add(site)
        change.emit(MonitorEvent(EventKind.SITE_OFFLINE, stamp=time.time(), site=site))
        for name in self._nodes_of(site):
            self._leaving.discard(name)
            self._show(change, name)

    def _nodes_of(self, site: str) -> list[str]:
        return [n for n in dict.fromkeys((*self._reported, *self._leaving)) if _site(n) == site]

    def _show(self, change: BookUpdate, name: str) -> None:
        """Set ``name``'s presence and status in the book by the rule (module doc)."""
        state = change.get(name)
        if state is None:
            return
        site = _site(name)
        status = self._status.get(name)
        if site in self._held:  # presence kept as it was; an online node's values are the copy held
            if state.online:
                self._staled.add(name)
                _set_status(change, state, STALE, by_site=True)
            else:
                change.set_status(state, status)  # no event: offline
            return
        by_status = name in self._staled  # the status its site's hold gave it, back as its gateway says
        self._staled.discard(name)
        online = (
            self._reported.get(name, False)
            and (name in self._alive or name in self._leaving)  # leaving: online until confirmed
            and site not in self._down
        )
        if online == state.online:
            _set_status(change, state, status, by_site=by_status)
            return
        by_site = site in self._down if not online else name in self._dropped
        if by_site and not online:
            self._dropped.add(name)
        elif online:
            self._dropped.discard(name)
            change.set_status(state, status)  # no event: offline yet (its online event carries it)
        before = len(change.events)
        change.set_online(state, online)
        if by_site and len(change.events) > before:
            change.events[-1] = replace(change.events[-1], by_site=True)
        if not online:
            change.set_status(state, status)  # no event: offline now

    def sites_down(self) -> set[str]:
        """The sites seen up whose every gateway went since and stayed away past the hold
        (their ``site_offline``)."""
        return set(self._down)

    def missing(self, change: BookUpdate) -> list[str]:
        """The nodes whose token is alive but whose state the book does not hold."""
        return [n for n in self._alive if change.get(n) is None]

    def apply(self, book: StateBook, change: BookUpdate, name: str, msg: NodeStateMsg) -> Outcome:
        """Apply the state (or delta) ``msg`` of node ``name`` (``SITE/NODE``)."""
        seen = self._seen.get(name)
        if seen is not None and seen[0] == msg.gateway and msg.seq <= seen[1]:
            return OLD
        parameters = msg.parameters
        blame = {n: _blame(lc) for n, lc in msg.last_changes.items()}
        if msg.kind == "delta":
            held = change.get(name)
            if held is None or seen != (msg.gateway, msg.base):
                return GAP
            parameters = {n: e for n, e in held.parameters.items() if n not in msg.deleted}
            parameters.update(msg.parameters)
            kept = held.blame.items()  # a parameter re-sent brings its own last change (or none)
            blame = {**{n: b for n, b in kept if n in parameters and n not in msg.parameters}, **blame}
        self._seen[name] = (msg.gateway, msg.seq)
        state = change.node(name)
        if book.has_callbacks:
            _changes(change, name, state.parameters, parameters, msg)
        state.parameters = dict(parameters)
        state.blame = blame
        state.host, state.pid = msg.host, msg.pid
        state.revision, state.announced = msg.revision, msg.announced
        state.incarnation, state.origin = msg.incarnation, msg.origin
        self._reported[name] = msg.online
        self._status[name] = msg.status
        if not msg.online:  # offline as its gateway says: its coming back is its own
            self._dropped.discard(name)
        self._show(change, name)
        return HELD


def _changes(change: BookUpdate, name: str, old: Table, new: Table, msg: NodeStateMsg) -> None:
    """An event per parameter of ``name`` added, modified or deleted from ``old`` to ``new``."""
    stamp = time.time()
    for pname, (value, descriptor) in new.items():
        before = old.get(pname)
        if before is None:
            kind = EventKind.ADDED
        elif not before[0].same_as(value) or before[1] != descriptor:
            kind = EventKind.MODIFIED
        else:
            continue
        lc = msg.last_changes.get(pname)
        change.emit(
            MonitorEvent(
                kind, name, pname, value, descriptor, msg.revision, stamp, msg.incarnation, last_change=lc
            )
        )
    for pname, (value, descriptor) in old.items():
        if pname not in new:
            change.emit(
                MonitorEvent(
                    EventKind.DELETED, name, pname, value, descriptor, msg.revision, stamp, msg.incarnation
                )
            )


def _set_status(change: BookUpdate, state: NodeState, status: str | None, *, by_site: bool) -> None:
    """Set ``state``'s status; its ``status`` event, if any, marked ``by_site`` when its site's."""
    before = len(change.events)
    change.set_status(state, status)
    if by_site and len(change.events) > before:
        change.events[-1] = replace(change.events[-1], by_site=True)


def _blame(lc: LastChange) -> Blame:
    return (lc.who, lc.verified, lc.via, lc.time_ns, lc.revision)


def _site(name: str) -> str:
    return name.split("/", 1)[0]
