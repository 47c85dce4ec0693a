"""The remote monitor's rules (paramdds.zenoh.monitor_rules), without a session."""

from __future__ import annotations

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.monitor_events import MonitorEvent
from paramdds.core.results import LastChange
from paramdds.core.state_book import StateBook
from paramdds.core.values import ParameterValue
from paramdds.zenoh.codec import NodeStateMsg
from paramdds.zenoh.monitor_rules import GAP, HELD, OLD, Outcome, RemoteStates

NODE = "s1/n"


def state(seq: int, online: bool = True, gateway: str = "g1", **params: object) -> NodeStateMsg:
    table = {k: (ParameterValue.from_python(v), ParameterDescriptor(k)) for k, v in params.items()}
    return NodeStateMsg("s1", "n", gateway, seq, online, revision=seq, announced=len(table), parameters=table)


def delta(seq: int, base: int, deleted: tuple[str, ...] = (), **params: object) -> NodeStateMsg:
    msg = state(seq, **params)
    msg.kind, msg.base, msg.deleted = "delta", base, list(deleted)
    return msg


class Remote:
    """A book and the rules, driven as the Zenoh feed drives them."""

    def __init__(self) -> None:
        self.events: list[MonitorEvent] = []
        self.book = StateBook(on_event=self.events.append)
        self.rules = RemoteStates()

    def apply(self, msg: NodeStateMsg) -> tuple[Outcome, list[tuple[str, str]]]:
        self.events.clear()
        with self.book.update() as change:
            outcome = self.rules.apply(self.book, change, NODE, msg)
        return outcome, [(e.event.value, e.name) for e in self.events]

    def token(self, alive: bool) -> tuple[bool, list[str]]:
        self.events.clear()
        with self.book.update() as change:
            came_back = self.rules.token(change, NODE, alive)
        return came_back, [e.event.value for e in self.events]

    def values(self) -> dict[str, object]:
        return {k: v.value for k, (v, _) in self.book.snapshot()[NODE].parameters.items()}


def test_a_node_is_online_while_its_gateway_says_so_and_its_token_is_alive() -> None:
    r = Remote()
    assert r.apply(state(1, a=1)) == (HELD, [("added", "a")])  # no token yet: not online
    assert r.token(True) == (False, ["online"])
    assert r.token(False) == (False, ["offline"])
    assert r.token(True) == (True, ["online"])  # came back: the feed asks for the state again
    assert r.apply(state(2, online=False, a=1)) == (HELD, [("offline", "")])


def test_an_older_or_the_same_state_of_the_gateway_changes_nothing() -> None:
    r = Remote()
    r.apply(state(5, a=1))
    assert r.apply(state(5, a=2)) == (OLD, [])
    assert r.apply(state(4, a=3)) == (OLD, [])
    assert r.values() == {"a": 1}
    assert r.apply(state(1, gateway="g2", a=4)) == (HELD, [("modified", "a")])  # another gateway's


def test_a_delta_applies_on_the_state_it_follows_and_else_is_a_gap() -> None:
    r = Remote()
    assert r.apply(delta(2, base=1, a=1)) == (GAP, [])  # nothing held yet
    r.apply(state(1, a=1, b=2))
    assert r.apply(delta(3, base=2, c=1)) == (GAP, [])  # seq 2 was missed
    assert r.apply(delta(2, base=1, deleted=("b",), a=5)) == (HELD, [("modified", "a"), ("deleted", "b")])
    assert r.values() == {"a": 5}


def test_the_same_table_again_is_no_event() -> None:
    r = Remote()
    r.apply(state(1, a=1, b=[1.0, 2.0]))
    assert r.apply(state(2, a=1, b=[1.0, 2.0])) == (HELD, [])


def test_tokens_found_by_a_first_get_do_not_revive_one_seen_going() -> None:
    r = Remote()
    r.token(False)
    with r.book.update() as change:
        r.rules.tokens_found([NODE, "s1/m"])
        assert r.rules.missing(change) == ["s1/m"]


def test_each_parameter_holds_the_last_change_its_state_says_and_its_event_carries_it() -> None:
    alice = LastChange("alice", False, "zenoh", 10, 1)
    bob = LastChange("bob", True, "cli", 20, 2)
    r = Remote()
    full = state(1, a=1, b=2, c=3)
    full.last_changes = {"a": alice, "b": alice}  # c: its node keeps no blame
    r.apply(full)
    assert {e.name: e.last_change for e in r.events} == {"a": alice, "b": alice, "c": None}
    held = r.book.snapshot()[NODE]
    assert (held.last_change("a"), held.last_change("c")) == (alice, None)

    step = delta(2, base=1, deleted=("c",), a=5)
    step.last_changes = {"a": bob}
    assert r.apply(step) == (HELD, [("modified", "a"), ("deleted", "c")])
    assert r.events[0].last_change == bob and r.events[1].last_change is None
    held = r.book.snapshot()[NODE]
    assert {n: held.last_change(n) for n in held.parameters} == {"a": bob, "b": alice}
    # the same value set again by someone else: no event, and the blame follows
    again = delta(3, base=2, b=2)
    again.last_changes = {"b": bob}
    assert r.apply(again) == (HELD, [])
    assert r.book.last_change(NODE, "b") == bob
    # re-sent without one (an older gateway): unknown, never the stale author
    assert r.apply(delta(4, base=3, b=7)) == (HELD, [("modified", "b")])
    assert r.book.last_change(NODE, "b") is None and r.book.last_change(NODE, "a") == bob
