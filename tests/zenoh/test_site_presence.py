"""A whole site going offline and coming back (paramdds.zenoh.monitor_rules), without a
session: one site event, its nodes' events marked ``by_site``, and a token's going
believed only once the router confirms it (whatever the order of the tokens, and where
the subscriber reported the wrong token gone). A site is held ``stale`` before it goes
offline (the hold); the tests of the site's other events use a site without one (``hold=0``)."""

from __future__ import annotations

import json

import pytest

from paramdds.core.monitor_events import EventKind, MonitorEvent
from paramdds.core.state_book import StateBook
from paramdds.zenoh.codec import NodeStateMsg
from paramdds.zenoh.monitor_rules import DOUBT_FOR, Confirmed, RemoteStates

NODES = [f"north/n{k}" for k in range(25)]
SITE_STATUS = EventKind.SITE_STATUS


class Site:
    """A book and the rules holding 25 online nodes of site ``north`` and one of ``south``; a
    site whose every gateway went is held ``hold`` seconds (0: offline at once)."""

    def __init__(self, hold: float = 0.0) -> None:
        self.events: list[MonitorEvent] = []
        self.book = StateBook(on_event=self.events.append)
        self.rules = RemoteStates(hold)
        self.now = 100.0  # the feed's clock (seconds)
        self.gateway("north", "g1", True)
        self.gateway("south", "g9", True)
        for name in [*NODES, "south/n0"]:
            site, node = name.split("/")
            with self.book.update() as change:
                self.rules.apply(self.book, change, name, NodeStateMsg(site, node, "g", 1, True))
            self.token(name, True)
        self.events.clear()

    def gateway(self, site: str, gateway: str, alive: bool) -> bool:
        """A gateway's token came or went; True when the feed asks for the site's states."""
        if not alive:  # reported gone: believed at confirm
            with self.book.update():
                self.rules.gateway_went(site, gateway)
            return False
        with self.book.update() as change:
            return self.rules.gateway(change, site, gateway, alive)

    def token(self, name: str, alive: bool) -> None:
        with self.book.update() as change:
            self.rules.token(change, name, alive)

    def confirm(self, site: str, gateways: set[str], alive: set[str], mark: int | None = None) -> list[str]:
        """What the router holds of ``site``, asked after ``mark`` (default: now); the nodes back."""
        return self.confirmed(site, gateways, alive, mark).back

    def confirmed(self, site: str, gateways: set[str], alive: set[str], mark: int | None = None) -> Confirmed:
        with self.book.update() as change:
            at = self.rules.mark() if mark is None else mark
            return self.rules.confirm(change, site, at, gateways, alive, self.now)

    def lines(self) -> list[str]:
        """What a log shows: the events not folded into their site's."""
        shown = [
            f"{e.event.value} {e.site or e.node}" + (f" {e.status or 'ok'}" if e.event is SITE_STATUS else "")
            for e in self.events
            if not e.by_site
        ]
        self.events.clear()
        return shown

    def online(self) -> set[str]:
        return {n for n, s in self.book.snapshot().items() if s.online}


def test_a_site_whose_gateway_went_is_one_event_whatever_the_order_of_its_tokens() -> None:
    s = Site()
    for name in NODES[:10]:  # some node tokens go first: the site's gateway is still up
        s.token(name, False)
    assert s.lines() == [] and s.online() == {*NODES, "south/n0"}  # until the router confirms
    s.gateway("north", "g1", False)
    for name in NODES[10:]:
        s.token(name, False)
    assert s.lines() == [] and s.online() == {*NODES, "south/n0"}
    assert s.confirm("north", set(), set()) == []
    offline = [e for e in s.events if e.event is EventKind.OFFLINE]
    assert sorted(e.node for e in offline) == sorted(NODES) and all(e.by_site for e in offline)
    assert s.lines() == ["site_offline north"]
    assert s.online() == {"south/n0"}
    assert s.confirm("north", set(), set()) == []
    assert s.lines() == []


@pytest.mark.parametrize("gateway_first", [True, False])
def test_a_site_coming_back_is_one_event_and_its_nodes_come_back_with_it(gateway_first: bool) -> None:
    s = Site()
    s.gateway("north", "g1", False)
    for name in NODES:
        s.token(name, False)
    s.confirm("north", set(), set())
    assert s.lines() == ["site_offline north"]
    if gateway_first:  # reconnected (a new session: another token); the node tokens in any order
        s.gateway("north", "g2", True)
    for name in NODES:
        s.token(name, True)
    if not gateway_first:
        assert s.online() == {"south/n0"}  # no gateway of the site yet
        s.gateway("north", "g2", True)
    online = [e for e in s.events if e.event is EventKind.ONLINE]
    assert sorted(e.node for e in online) == sorted(NODES) and all(e.by_site for e in online)
    assert s.lines() == ["site_online north"]
    assert s.online() == {*NODES, "south/n0"}


def test_a_node_that_goes_alone_goes_offline_once_confirmed_as_its_own_event() -> None:
    s = Site()
    s.token("north/n3", False)
    assert s.lines() == [] and "north/n3" in s.online()
    s.confirm("north", {"g1"}, set(NODES) - {"north/n3"})
    assert s.lines() == ["offline north/n3"]


def test_a_node_token_back_before_the_confirmation_is_no_flap() -> None:
    s = Site()  # a standby gateway took over at once: the node's token went and came back
    s.token("north/n3", False)
    s.token("north/n3", True)
    s.confirm("north", {"g1"}, set(NODES))
    assert s.lines() == []


def test_a_token_reported_gone_that_the_router_still_holds_stays_online() -> None:
    s = Site()  # a subscriber told a token of north gone when another site's session dropped
    s.token("north/n3", False)
    s.gateway("north", "g1", False)
    assert s.confirm("north", {"g1"}, set(NODES)) == []
    assert s.lines() == [] and s.online() == {*NODES, "south/n0"}


def test_a_site_whose_gateway_token_was_never_reported_gone_goes_offline_once_confirmed() -> None:
    s = Site()  # the node tokens were reported gone, the gateway's was not (nor was any other)
    for name in NODES:
        s.token(name, False)
    s.confirm("north", set(), set())
    assert s.lines() == ["site_offline north"]
    assert s.online() == {"south/n0"}


def test_a_confirmation_asked_before_a_token_came_back_leaves_it_to_its_event() -> None:
    s = Site()
    s.token("north/n3", False)
    with s.book.update():
        mark = s.rules.mark()  # the router is asked here: it answers without n3
    s.token("north/n3", True)  # then n3 comes back
    s.confirm("north", {"g1"}, set(NODES) - {"north/n3"}, mark=mark)
    assert s.lines() == [] and "north/n3" in s.online()


def test_a_get_that_misses_tokens_never_seen_going_takes_nothing_offline_until_asked_again() -> None:
    """The hour-long soak: a restarted server's tokens went, and every get of that confirmation
    ended at once with no reply: the whole healthy site was shown offline for 10 s."""
    s = Site()
    restarted = NODES[:5]
    for name in restarted:
        s.token(name, False)
    first = s.confirmed("north", {"g1"}, set())  # the router is asked: the get finds no token at all
    assert s.lines() == [f"offline {n}" for n in restarted]  # their going was seen: believed
    assert first.again and s.online() == {*NODES[5:], "south/n0"}  # the others: asked again
    s.now += DOUBT_FOR / 2
    assert s.confirmed("north", {"g1"}, set(NODES[5:])).again is False  # found: no event
    assert s.lines() == [] and s.online() == {*NODES[5:], "south/n0"}


def test_a_token_never_seen_going_that_the_router_still_lacks_later_is_gone() -> None:
    s = Site()  # a subscriber that missed the going (a session dropped by the router)
    assert s.confirmed("north", {"g1"}, set(NODES) - {"north/n3"}).again
    assert s.lines() == [] and "north/n3" in s.online()
    s.now += DOUBT_FOR / 2
    assert s.confirmed("north", {"g1"}, set(NODES) - {"north/n3"}).again  # not yet
    s.now += DOUBT_FOR / 2
    assert s.confirmed("north", {"g1"}, set(NODES) - {"north/n3"}).again is False
    assert s.lines() == ["offline north/n3"]


def test_a_token_the_router_holds_that_was_seen_gone_is_back_and_asked_for() -> None:
    s = Site()
    s.token("north/n3", False)
    s.confirm("north", {"g1"}, set(NODES) - {"north/n3"})
    assert s.lines() == ["offline north/n3"]
    assert s.confirm("north", {"g1"}, set(NODES)) == ["north/n3"]  # its coming back was missed
    assert s.lines() == ["online north/n3"]


def test_a_site_with_a_gateway_left_stays_up() -> None:
    s = Site()
    s.gateway("north", "g2", True)  # a standby
    s.gateway("north", "g1", False)
    s.confirm("north", {"g2"}, set(NODES))
    assert s.lines() == []
    assert s.online() == {*NODES, "south/n0"}


def test_a_node_offline_when_its_site_came_back_comes_online_as_its_own_event() -> None:
    s = Site()
    s.gateway("north", "g1", False)
    s.confirm("north", set(), set(NODES))
    s.gateway("north", "g1b", True)
    with s.book.update() as change:  # the gateway, asked again, says n3 is offline now
        s.rules.apply(s.book, change, "north/n3", NodeStateMsg("north", "n3", "g", 2, False))
    s.lines()
    with s.book.update() as change:
        s.rules.apply(s.book, change, "north/n3", NodeStateMsg("north", "n3", "g", 3, True))
    assert s.lines() == ["online north/n3"]


def _site_went(s: Site) -> list[MonitorEvent]:
    for name in NODES[:3]:
        s.token(name, False)
    s.gateway("north", "g1", False)
    s.confirm("north", set(), set())
    events = list(s.events)
    s.events.clear()
    return events


def test_watch_prints_one_line_for_a_site_that_went_and_came_back(capsys: pytest.CaptureFixture[str]) -> None:
    from paramdds.cli._events import EventPrinter

    s = Site()
    went = _site_went(s)
    s.gateway("north", "g2", True)
    for name in NODES:
        s.token(name, True)
    came = list(s.events)
    for output in ("text", "json"):
        printer = EventPrinter(output, [])
        printer.synced()
        for event in [*went, *came]:
            printer(event)
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "synced" and out[1:3] == ["site_offline north", "site_online north"]
    assert out[3] == '{"event": "synced"}'
    assert [json.loads(line)["event"] for line in out[4:]] == ["site_offline", "site_online"]
    assert json.loads(out[4])["site"] == "north"


def test_the_web_console_logs_one_line_for_a_site_and_updates_every_node_row() -> None:
    import asyncio
    from typing import cast

    from paramdds.dds.monitor import ParameterMonitor
    from paramdds.web.hub import Hub
    from paramdds.web.view import StateView

    s = Site()
    went = _site_went(s)

    async def run() -> list[str]:
        hub = Hub(StateView(cast(ParameterMonitor, s.book)), asyncio.get_running_loop())
        sub = hub.subscribe("")
        for event in went:
            hub.on_event(event)
        await asyncio.sleep(0.2)
        return [sub.queue.get_nowait() or "" for _ in range(sub.queue.qsize())]

    nodes, log = asyncio.run(run())
    assert nodes.startswith("event: nodes") and all(f'"node":"{n}"' in nodes for n in NODES)
    entries = json.loads(log.split("data: ", 1)[1])
    assert [(e["event"], e["site"]) for e in entries["events"]] == [("site_offline", "north")]
    assert entries["skipped"] == 0
