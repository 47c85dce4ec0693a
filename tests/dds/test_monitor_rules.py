"""The monitor's rules on DDS samples (paramdds.dds.monitor_rules), without a reader.

The samples are the decoded ``ParameterEvents`` a reader delivers; what the reader says
of each instance is a plain record (state and writer), so no DDS entity is made here.
"""

from __future__ import annotations

from dataclasses import dataclass

from cyclonedds.core import InstanceState

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.monitor_events import EventKind, MonitorEvent
from paramdds.core.results import LastChange
from paramdds.core.state_book import StateBook
from paramdds.core.values import NOT_SET, ParameterValue
from paramdds.dds.filters import gone_tag, origin_tag
from paramdds.dds.monitor_rules import apply_sample
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.state import StateKey, StateSample


@dataclass(frozen=True)
class Info:
    instance_state: int = InstanceState.Alive
    publication_handle: int = 1


ALIVE = Info()
DISPOSED = Info(InstanceState.NotAliveDisposed)
NO_WRITERS = Info(InstanceState.NotAliveNoWriters)


def presence(
    revision: int, count: int, *, incarnation: int = 1, tags: tuple[str, ...] = (), pid: int = 10
) -> StateSample:
    return StateSample(
        node_id="n",
        name="",
        kind=wire.EVENT_PRESENCE,
        revision=revision,
        stamp=0.0,
        value=ParameterValue.from_python(tags) if tags else NOT_SET,  # the server's tags
        descriptor=ParameterDescriptor(""),
        host="h",
        pid=pid,
        parameter_count=count,
        incarnation=incarnation,
    )


def param(
    name: str,
    value: object,
    revision: int,
    *,
    incarnation: int = 1,
    who: str = "",
    verified: bool = False,
    via: str = "",
    stamp: float = 0.0,
) -> StateSample:
    return StateSample(
        node_id="n",
        name=name,
        kind=wire.EVENT_PARAMETER,
        revision=revision,
        stamp=stamp,
        value=ParameterValue.from_python(value),
        descriptor=ParameterDescriptor(name),
        host="",
        pid=0,
        parameter_count=0,
        incarnation=incarnation,
        who=who,
        verified=verified,
        via=via,
    )


class Monitor:
    """A book and its events, fed one batch at a time as a reader would."""

    def __init__(self) -> None:
        self.events: list[MonitorEvent] = []
        self.book = StateBook(on_event=self.events.append)

    def feed(self, *batch: tuple[StateSample | StateKey, Info]) -> list[tuple[str, str, int]]:
        self.events.clear()
        with self.book.update() as change:
            for sample, info in batch:
                apply_sample(self.book, change, sample, info)
        return [(e.event.value, e.name, e.revision) for e in self.events]


def test_a_late_joiner_sees_the_table_then_presence_and_each_event_carries_the_origin() -> None:
    m = Monitor()
    told = m.feed((param("a", 1, 1), ALIVE), (presence(1, 1, tags=(origin_tag("ros2"),)), ALIVE))
    assert told == [("online", "", 1), ("added", "a", 1)]  # the early event waited for the presence
    assert {e.origin for e in m.events} == {"ros2"}
    assert m.book.snapshot()["n"].complete


def test_the_same_value_again_is_no_event_and_a_change_is_modified() -> None:
    m = Monitor()
    m.feed((presence(1, 1), ALIVE), (param("a", 1, 1), ALIVE))
    assert m.feed((param("a", 1, 1), ALIVE)) == []
    assert m.feed((param("a", 2, 2), ALIVE)) == [("modified", "a", 2)]


def test_a_deletion_carries_the_revision_of_the_presence_that_follows() -> None:
    m = Monitor()
    m.feed((presence(1, 2), ALIVE), (param("a", 1, 1), ALIVE), (param("b", 1, 1), ALIVE))
    assert m.feed((StateKey("n", "b"), DISPOSED)) == []
    assert m.feed((presence(5, 1), ALIVE)) == [("deleted", "b", 5)]


def test_a_value_delivered_with_its_instance_disposed_is_a_deletion_not_an_addition() -> None:
    # a late joiner whose retained sample was disposed before its take: Cyclone hands over
    # the data with the instance already NOT_ALIVE_DISPOSED, and no separate dispose
    m = Monitor()
    told = m.feed((presence(4, 1), ALIVE), (param("a", 1, 1), ALIVE), (param("gone", 1, 2), DISPOSED))
    assert told == [("online", "", 4), ("added", "a", 4)]  # shown at the presence's revision
    assert set(m.book.snapshot()["n"].parameters) == {"a"}
    m.feed((param("b", 1, 5), ALIVE), (presence(5, 2), ALIVE))
    assert m.feed((param("b", 1, 5), DISPOSED), (presence(6, 1), ALIVE)) == [("deleted", "b", 6)]
    assert set(m.book.snapshot()["n"].parameters) == {"a"}


def test_no_writers_on_a_parameter_keeps_its_value_and_on_presence_is_offline() -> None:
    m = Monitor()
    m.feed((presence(1, 1), ALIVE), (param("a", 1, 1), ALIVE))
    assert m.feed((StateKey("n", "a"), NO_WRITERS), (StateKey("n", ""), NO_WRITERS)) == [("offline", "", 1)]
    held = m.book.snapshot()["n"]
    assert not held.online and "a" in held.parameters


def test_a_restart_by_the_same_writer_shows_offline_restarted_online() -> None:
    m = Monitor()
    m.feed((presence(7, 1), ALIVE), (param("a", 1, 7), ALIVE))
    told = m.feed((param("a", 1, 1, incarnation=2), ALIVE), (presence(1, 1, incarnation=2), ALIVE))
    assert [kind for kind, _, _ in told] == ["offline", "restarted", "online"]
    assert m.book.snapshot()["n"].incarnation == 2


def test_an_event_never_shows_a_revision_lower_than_one_shown_before() -> None:
    m = Monitor()
    m.feed((presence(3, 2), ALIVE), (param("a", 1, 3), ALIVE))
    assert m.feed((param("b", 1, 2), ALIVE)) == [("added", "b", 3)]  # re-delivered, written at 2


def test_a_second_host_of_the_node_is_a_duplicate_until_it_says_it_is_gone() -> None:
    m = Monitor()
    m.feed((presence(1, 0, pid=10), ALIVE))
    m.feed((presence(1, 0, pid=11, incarnation=2), Info(publication_handle=2)))
    assert m.book.snapshot()["n"].duplicates == ["pid 10 on h"]
    m.feed((presence(2, 0, pid=11, incarnation=2, tags=(gone_tag("h", 10),)), Info(publication_handle=2)))
    assert m.book.snapshot()["n"].duplicates == []


def test_other_nodes_than_the_book_keeps_are_skipped() -> None:
    m = Monitor()
    m.book = StateBook(nodes=["other"], on_event=m.events.append)
    assert m.feed((presence(1, 0), ALIVE)) == [] and m.book.snapshot() == {}


def test_without_callbacks_the_state_is_held_and_no_event_is_made() -> None:
    book = StateBook()
    with book.update() as change:
        apply_sample(book, change, presence(1, 1), ALIVE)
        apply_sample(book, change, param("a", 1, 1), ALIVE)
        apply_sample(book, change, StateKey("n", "a"), DISPOSED)
        assert [e.event for e in change.events] == [EventKind.ONLINE]  # presence events are state
    held = book.snapshot()["n"]
    assert held.parameters == {} and held.deleting == []


def test_each_parameter_holds_and_each_event_carries_its_last_change() -> None:
    m = Monitor()
    m.feed(
        (presence(1, 2), ALIVE),
        (param("a", 1, 1, who="start@h", verified=True, via="start", stamp=1.5), ALIVE),
    )
    started = LastChange("start@h", True, "start", 1_500_000_000, 1)
    assert m.events[-1].last_change == started
    assert m.book.last_change("n", "a") == started
    m.feed((param("a", 2, 2, who="alice", via="cli", stamp=2.25), ALIVE))
    alice = LastChange("alice", False, "cli", 2_250_000_000, 2)
    assert [e.last_change for e in m.events] == [alice]
    assert m.book.last_change("n", "a") == m.book.snapshot()["n"].last_change("a") == alice
    # the same sample again (re-sent after a stall) is no event; the same value set again by
    # another author is a new commit: an event, with its author
    assert m.feed((param("a", 2, 2, who="alice", via="cli", stamp=2.25), ALIVE)) == []
    bob = LastChange("bob", False, "web", 3_000_000_000, 3)
    assert m.feed((param("a", 2, 3, who="bob", via="web", stamp=3.0), ALIVE)) == [("modified", "a", 3)]
    assert m.events[-1].last_change == bob
    assert m.book.last_change("n", "a") == bob
    # a writer that keeps no blame: unknown (never the previous author's)
    m.feed((param("a", 3, 4), ALIVE))
    assert m.events[-1].last_change is None and m.book.last_change("n", "a") is None
    m.feed((param("b", 1, 5, who="carol", via="api"), ALIVE), (StateKey("n", "b"), DISPOSED))
    assert m.book.last_change("n", "b") is None  # deleted: no last change held
    assert m.book.last_change("n", "nothing") is None and m.book.last_change("other", "a") is None


def test_parameters_share_their_nodes_usual_last_change_and_never_take_one_not_theirs() -> None:
    """The parameters of a node's table written by one change share one held last change
    (``NodeState.shared_blame``); a parameter whose writer kept no blame, or whose change was
    another, keeps its own."""
    m = Monitor()

    def start(name: str) -> StateSample:  # the value the node started with, at revision 1
        return param(name, 1, 1, who="start@h", verified=True, via="start", stamp=1.0)

    m.feed(
        (param("unknown", 0, 1), ALIVE),  # before any with blame: unknown, whatever comes next
        (start("a"), ALIVE),
        (start("b"), ALIVE),
        (presence(1, 3), ALIVE),
    )
    started = LastChange("start@h", True, "start", 1_000_000_000, 1)
    assert [m.book.last_change("n", p) for p in ("unknown", "a", "b")] == [None, started, started]
    held = m.book.snapshot()["n"]
    assert held.blame["a"] is held.blame["b"] and "unknown" not in held.blame  # one tuple for both
    m.feed((param("a", 2, 2, who="alice", via="cli", stamp=2.0), ALIVE), (param("c", 1, 3), ALIVE))
    alice = LastChange("alice", False, "cli", 2_000_000_000, 2)
    assert [m.book.last_change("n", p) for p in ("unknown", "a", "b", "c")] == [None, alice, started, None]
    m.feed((start("a"), ALIVE))  # a re-delivered sample of the start
    held = m.book.snapshot()["n"]
    assert [held.last_change(p) for p in ("unknown", "a", "b", "c")] == [None, started, started, None]
    m.feed((StateKey("n", "b"), DISPOSED), (param("b", 5, 4), ALIVE))  # deleted, then added without blame
    assert m.book.last_change("n", "b") is None and m.book.last_change("n", "a") == started
