"""A ParameterMonitor takes any feed: the one monitor, whatever transport fills it."""

from __future__ import annotations

import threading
import time

import pytest

from paramdds.core.state_book import StateBook
from paramdds.dds.monitor import EventKind, MonitorEvent, ParameterMonitor
from paramdds.dds.qos import QosProfiles


class OneNode:
    """A feed that holds one node online, then says the state is in."""

    def __init__(self) -> None:
        self.book: StateBook | None = None
        self.closed_after_book = False

    def start(self, book: StateBook) -> None:
        self.book = book
        with book.update() as change:
            state = change.node("arm")
            state.announced = 0
            change.set_online(state, True)
        book.mark_synced()

    def close(self) -> None:
        assert self.book is not None
        self.closed_after_book = self.book.closed


def test_a_monitor_over_a_feed_offers_the_same_calls_and_events() -> None:
    events: list[MonitorEvent] = []
    feed = OneNode()
    with ParameterMonitor(feed, nodes=["arm"], on_event=events.append) as monitor:
        assert monitor.wait_synced(1.0) and monitor.synced
        assert monitor.wait_complete(["/arm"], 1.0)
        assert monitor.snapshot()["arm"].online
        assert [e.event for e in events] == [EventKind.ONLINE, EventKind.SYNCED]
    assert feed.closed_after_book  # the waits end before the feed lets go


def test_qos_profiles_belong_to_the_dds_feed() -> None:
    with pytest.raises(TypeError):
        ParameterMonitor(OneNode(), QosProfiles.load())


class Trickle:
    """A feed that says it is synced at once, then brings node ``arm`` online ``late`` s later
    and, with ``every`` set, keeps delivering a status event that often until closed."""

    def __init__(self, late: float, every: float | None = None) -> None:
        self.late, self.every = late, every
        self.done = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self, book: StateBook) -> None:
        book.mark_synced()
        self.thread = threading.Thread(target=self._run, args=(book,), daemon=True)
        self.thread.start()

    def _run(self, book: StateBook) -> None:
        if self.done.wait(self.late):
            return
        with book.update() as change:
            state = change.node("arm")
            state.announced = 0
            change.set_online(state, True)
        flip = False
        while self.every is not None and not self.done.wait(self.every):
            flip = not flip
            with book.update() as change:
                change.set_status(change.node("arm"), "stale" if flip else None)

    def close(self) -> None:
        self.done.set()
        if self.thread is not None:
            self.thread.join()


def test_settle_waits_past_an_early_sync_for_a_node_discovered_late() -> None:
    with ParameterMonitor(Trickle(late=0.2)) as monitor:
        assert monitor.synced and "arm" not in monitor.snapshot()  # the feed's own sync came first
        assert monitor.settle(5.0)
        assert monitor.snapshot()["arm"].online


def test_settle_says_false_when_events_never_stop_or_it_is_stopped() -> None:
    with ParameterMonitor(Trickle(late=0.0, every=0.02)) as monitor:
        started = time.monotonic()
        assert not monitor.settle(0.8, started=started)
        assert 0.8 <= time.monotonic() - started < 3.0
        stop = threading.Event()
        threading.Timer(0.2, stop.set).start()
        started = time.monotonic()
        assert not monitor.settle(10.0, stop=stop)
        assert time.monotonic() - started < 3.0  # ended by stop, not by its 10 s
