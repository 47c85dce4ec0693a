"""The monitor's book (paramdds.core.state_book): its rules, without any transport."""

from __future__ import annotations

import threading
import time

from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.monitor_events import EventKind, MonitorEvent, NodeState
from paramdds.core.state_book import BookUpdate, StateBook
from paramdds.core.values import ParameterValue


def _book() -> tuple[StateBook, list[MonitorEvent]]:
    events: list[MonitorEvent] = []
    return StateBook(on_event=events.append), events


def test_an_update_makes_nodes_and_delivers_its_events_in_order_once_it_ends() -> None:
    book, events = _book()
    with book.update() as change:
        state = change.node("n")
        assert change.get("n") is state and change.get("other") is None
        change.emit(MonitorEvent(EventKind.ADDED, "n", "a"))
        change.emit(MonitorEvent(EventKind.ADDED, "n", "b"))
        assert events == []  # not under the lock
    assert [e.name for e in events] == ["a", "b"]
    assert list(book.snapshot()) == ["n"]


def test_an_update_that_raises_delivers_nothing() -> None:
    book, events = _book()
    try:
        with book.update() as change:
            change.emit(MonitorEvent(EventKind.ADDED, "n", "a"))
            raise RuntimeError("feed failed")
    except RuntimeError:
        pass
    assert events == []


def test_going_online_and_offline_is_an_event_once_and_offline_forgets_the_writer() -> None:
    book, events = _book()
    with book.update() as change:
        state = change.node("n")
        state.revision, state.incarnation, state.status = 4, 9, "stale"
        change.set_online(state, True)
        change.set_online(state, True)
        state.writer, state.duplicates = 7, ["pid 1 on h"]
        change.set_online(state, False)
    assert [e.event for e in events] == [EventKind.ONLINE, EventKind.OFFLINE]
    assert (events[0].revision, events[0].incarnation, events[0].status) == (4, 9, "stale")
    held = book.snapshot()["n"]
    assert (held.online, held.writer, held.duplicates) == (False, 0, [])


def test_a_status_change_is_an_event_only_on_an_online_node() -> None:
    book, events = _book()
    with book.update() as change:
        state = change.node("n")
        change.set_status(state, "unreachable")  # offline: no event, but held
        change.set_online(state, True)
        change.set_status(state, "unreachable")  # unchanged: no event
        change.set_status(state, None)
    assert [(e.event, e.status) for e in events] == [
        (EventKind.ONLINE, "unreachable"),
        (EventKind.STATUS, None),
    ]


@given(st.lists(st.integers(min_value=0, max_value=1000), min_size=1))
def test_an_event_never_shows_a_lower_revision_than_before(revisions: list[int]) -> None:
    state = NodeState("n")
    shown = [BookUpdate.shown(state, r) for r in revisions]
    assert shown == [max(revisions[: i + 1]) for i in range(len(revisions))]


def test_a_failing_callback_costs_neither_the_others_nor_the_rest() -> None:
    book, events = _book()
    seen: list[str] = []

    def fails(event: MonitorEvent) -> None:
        raise ValueError(event.name)

    book.add_callback(fails)
    book.add_callback(lambda e: seen.append(e.name))
    with book.update() as change:
        change.emit(MonitorEvent(EventKind.ADDED, "n", "a"))
        change.emit(MonitorEvent(EventKind.ADDED, "n", "b"))
    assert [e.name for e in events] == seen == ["a", "b"]


def test_the_nodes_filter_takes_ids_and_globs() -> None:
    book = StateBook(nodes=["robot1", "fleet/*"])
    assert book.wanted("robot1") and book.wanted("fleet/a") and not book.wanted("robot2")
    assert StateBook().wanted("anything")
    assert not StateBook().has_callbacks and StateBook(on_event=print).has_callbacks


def test_a_wait_wakes_when_an_update_ends() -> None:
    book = StateBook()

    def later() -> None:
        time.sleep(0.05)
        with book.update() as change:
            state = change.node("n")
            state.announced = 1
            state.parameters["x"] = (ParameterValue.from_python(1), ParameterDescriptor("x"))

    threading.Thread(target=later).start()
    assert book.wait_complete(["/n"], timeout=5.0)
    assert not book.wait_complete(["m"], timeout=0.01)


def test_synced_is_emitted_once_marked_and_wakes_its_waiters() -> None:
    book, events = _book()
    assert not book.synced and not book.wait_synced(0.0)
    threading.Timer(0.05, book.mark_synced).start()
    assert book.wait_synced(5.0) and book.synced
    assert [e.event for e in events] == [EventKind.SYNCED]


def test_closing_ends_the_waits() -> None:
    book = StateBook()
    threading.Timer(0.05, book.close).start()
    started = time.monotonic()
    assert not book.wait_until(lambda _s: False, timeout=10.0)
    assert time.monotonic() - started < 5.0 and book.closed


def test_a_snapshot_is_a_copy() -> None:
    book = StateBook()
    with book.update() as change:
        change.node("n").duplicates.append("pid 1 on h")
    copy = book.snapshot()
    copy["n"].duplicates.clear()
    copy["n"].parameters["x"] = (ParameterValue.from_python(1), ParameterDescriptor("x"))
    held = book.snapshot()["n"]
    assert held.duplicates == ["pid 1 on h"] and held.parameters == {}
