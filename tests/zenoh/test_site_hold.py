"""A site held ``stale`` before it is offline (paramdds.zenoh.monitor_rules), without a session:
a gateway back within the hold is one ``site_status`` pair and no presence event, one that
stays away makes the site ``site_offline`` once the hold is over, and a site back has its
states asked for again."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.monitor_events import EventKind
from paramdds.core.values import ParameterValue
from paramdds.zenoh.codec import NodeStateMsg
from paramdds.zenoh.monitor_rules import SITE_GRACE, SITE_HOLD

from .test_site_presence import NODES, Site

HOLD = 5.0
EVERY = {*NODES, "south/n0"}


def _drop(s: Site, nodes: list[str] = NODES) -> None:
    """north's gateway session dropped by the router: its gateway's token and its ``nodes``'
    tokens go, and the router confirms it :data:`SITE_GRACE` later."""
    s.gateway("north", "g1", False)
    for name in nodes:
        s.token(name, False)
    s.now += SITE_GRACE


def _statuses(s: Site) -> set[str | None]:
    return {st.status for n, st in s.book.snapshot().items() if n.startswith("north/")}


def test_the_hold_paramdds_sets_is_the_measured_one() -> None:
    assert SITE_HOLD == HOLD  # docs/zenoh.md's loss table and docs/decisions.md say why


def test_a_drop_shorter_than_the_hold_is_one_stale_and_back_pair_and_no_presence_event() -> None:
    s = Site(hold=HOLD)
    told: list[EventKind] = []

    def lines() -> list[str]:
        told.extend(e.event for e in s.events)
        return s.lines()

    _drop(s)
    held = s.confirmed("north", set(), set())
    assert held.hold_until == s.now + HOLD and not held.up
    assert lines() == ["site_status north stale"]  # one line: the nodes' own are by_site
    assert told.count(EventKind.STATUS) == len(NODES)
    assert s.online() == EVERY and _statuses(s) == {"stale"}
    s.now += 2.0
    assert s.gateway("north", "g2", True)  # back: the feed asks for the site's states again
    assert lines() == ["site_status north ok"]
    assert s.online() == EVERY and _statuses(s) == {None}
    for name in NODES:
        s.token(name, True)
    s.now = held.hold_until  # the hold's own confirmation, come anyway
    assert s.confirmed("north", {"g2"}, set(NODES)) == (False, [], False, None)
    assert lines() == [] and s.online() == EVERY
    presence = {EventKind.OFFLINE, EventKind.ONLINE, EventKind.SITE_OFFLINE, EventKind.SITE_ONLINE}
    assert told.count(EventKind.STATUS) == 2 * len(NODES) and not presence & set(told)


def test_a_drop_longer_than_the_hold_is_site_offline_once_the_hold_is_over() -> None:
    s = Site(hold=HOLD)
    _drop(s)
    until = s.confirmed("north", set(), set()).hold_until
    assert until is not None
    s.lines()
    s.now = until - 0.01  # a confirmation within the hold (another token went) changes nothing
    assert s.confirmed("north", set(), set()).hold_until == until
    assert s.lines() == [] and s.online() == EVERY
    s.now = until
    assert s.confirmed("north", set(), set()).hold_until is None
    offline = [e for e in s.events if e.event is EventKind.OFFLINE]
    assert sorted(e.node for e in offline) == sorted(NODES) and all(e.by_site for e in offline)
    assert s.lines() == ["site_offline north"]
    assert s.online() == {"south/n0"} and _statuses(s) == {None}  # offline, as their gateway said
    assert s.gateway("north", "g2", True)
    for name in NODES:
        s.token(name, True)
    assert s.lines() == ["site_online north"] and s.online() == EVERY


def test_a_gateway_the_router_holds_again_at_the_end_of_the_hold_ends_it() -> None:
    s = Site(hold=HOLD)  # its coming back was not reported: the hold's confirmation finds it
    _drop(s)
    until = s.confirmed("north", set(), set()).hold_until
    assert until is not None
    s.lines()
    s.now = until
    done = s.confirmed("north", {"g2"}, set(NODES))
    assert done.up and done.hold_until is None  # the feed asks for the site's states again
    assert s.lines() == ["site_status north ok"] and s.online() == EVERY and _statuses(s) == {None}


def test_a_node_whose_token_is_not_back_with_its_site_is_confirmed_on_its_own() -> None:
    s = Site(hold=HOLD)
    _drop(s)
    s.confirm("north", set(), set())
    s.gateway("north", "g2", True)
    for name in NODES[1:]:
        s.token(name, True)
    assert s.lines() == ["site_status north stale", "site_status north ok"]
    assert s.rules.unsure("north") and s.online() == EVERY  # the feed confirms it later
    done = s.confirmed("north", {"g2"}, set(NODES[1:]))
    assert not done.again and s.lines() == [f"offline {NODES[0]}"]


def test_a_change_published_during_the_drop_comes_with_the_site_asked_again() -> None:
    s = Site(hold=HOLD)
    value = ParameterValue.from_python

    def state(seq: int, v: float) -> NodeStateMsg:
        table = {"speed": (value(v), ParameterDescriptor("speed"))}
        return NodeStateMsg("north", "n0", "g", seq, True, revision=seq, announced=1, parameters=table)

    with s.book.update() as change:
        s.rules.apply(s.book, change, "north/n0", state(2, 1.0))
    _drop(s)
    s.confirm("north", set(), set())
    assert s.book.snapshot()["north/n0"].parameters["speed"][0].value == 1.0  # the copy held
    s.events.clear()
    # the change made on the site meanwhile was published while its session was down: lost
    asked = s.gateway("north", "g2", True)
    assert asked  # so the feed asks for the site's states: the reply carries it
    with s.book.update() as change:
        s.rules.apply(s.book, change, "north/n0", state(3, 2.5))
    assert [(e.event, e.name) for e in s.events if e.name] == [(EventKind.MODIFIED, "speed")]
    assert s.book.snapshot()["north/n0"].parameters["speed"][0].value == 2.5


def test_a_node_offline_before_the_drop_stays_offline_through_the_hold() -> None:
    s = Site(hold=HOLD)
    s.token(NODES[3], False)
    s.confirm("north", {"g1"}, set(NODES) - {NODES[3]})
    s.lines()
    others = [n for n in NODES if n != NODES[3]]
    _drop(s, others)
    s.confirm("north", set(), set())
    s.gateway("north", "g2", True)
    for name in others:
        s.token(name, True)
    assert s.lines() == ["site_status north stale", "site_status north ok"]
    assert s.online() == EVERY - {NODES[3]}
    assert not s.rules.unsure("north")


@settings(max_examples=60, deadline=None)
@given(
    away=st.floats(0.0, 3 * HOLD, allow_nan=False),
    tokens_first=st.booleans(),
)
def test_a_site_away_for_any_time_is_stale_then_back_or_offline_once(away: float, tokens_first: bool) -> None:
    """A gateway away ``away`` seconds after the confirmation (its node tokens back before or
    after its own): under the hold, one ``stale``/``ok`` pair and nothing else; past it, one
    ``site_offline`` at the end of the hold and one ``site_online``; every node online at the end."""
    s = Site(hold=HOLD)
    _drop(s)
    start = s.now
    until = s.confirmed("north", set(), set()).hold_until
    assert until == start + HOLD
    if away >= HOLD:  # the hold's confirmation comes first (the feed's timer)
        s.now = until
        s.confirm("north", set(), set())
    s.now = start + away
    order = [*(("token", n) for n in NODES), ("gateway", "g2")]
    for kind, what in order if tokens_first else reversed(order):
        if kind == "token":
            s.token(what, True)
        else:
            s.gateway("north", what, True)
    s.now += SITE_GRACE
    done = s.confirmed("north", {"g2"}, set(NODES))
    assert done.hold_until is None and not done.again
    if away < HOLD:
        assert s.lines() == ["site_status north stale", "site_status north ok"]
    else:
        assert s.lines() == ["site_status north stale", "site_offline north", "site_online north"]
    assert s.online() == EVERY and _statuses(s) == {None}


def test_watch_prints_one_line_for_a_site_held_and_back(capsys: pytest.CaptureFixture[str]) -> None:
    from paramdds.cli._events import EventPrinter

    s = Site(hold=HOLD)
    _drop(s)
    s.confirm("north", set(), set())
    s.gateway("north", "g2", True)
    for output in ("text", "json"):
        printer = EventPrinter(output, [])
        printer.synced()
        for event in s.events:
            printer(event)
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == ["synced", "site_status north stale", "site_status north ok"]
    assert [(d["event"], d["site"], d["status"]) for d in map(json.loads, out[4:])] == [
        ("site_status", "north", "stale"),
        ("site_status", "north", None),
    ]
