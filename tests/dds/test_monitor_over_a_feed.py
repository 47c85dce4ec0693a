"""A ParameterMonitor takes any feed: the one monitor, whatever transport fills it."""

from __future__ import annotations

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
