"""The tracker, pure: each change once, skipped revisions filled from history or recorded as a gap."""

from __future__ import annotations

from collections.abc import Sequence

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.history import HistoryRecord
from paramdds.core.monitor_events import EventKind, MonitorEvent, NodeState
from paramdds.core.results import LastChange
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.record.tracker import Out, Tracker

T = ParameterType
NOW = 1_795_000_000_000_000_000


def dv(x: float) -> ParameterValue:
    return ParameterValue.of(T.DOUBLE, x)


D = ParameterDescriptor("v", T.DOUBLE)


def blame(rev: int, who: str = "alice") -> tuple[str, bool, str, int, int]:
    return (who, False, "cli", NOW + rev, rev)


def state(revision: int = 3) -> dict[str, NodeState]:
    st = NodeState("n", online=True, revision=revision, incarnation=1, announced=1)
    st.parameters["v"] = (dv(1.0), D)
    st.blame["v"] = blame(revision)
    return {"n": st}


def change(rev: int, x: float, who: str = "alice", name: str = "v") -> MonitorEvent:
    return MonitorEvent(
        EventKind.MODIFIED, "n", name, dv(x), D, rev, (NOW + rev) / 1e9, 1,
        last_change=LastChange(who, False, "cli", NOW + rev, rev),
    )  # fmt: skip


def record(rev: int, x_old: float, x: float, name: str = "v") -> HistoryRecord:
    return HistoryRecord(rev, "n", name, rev, NOW + rev, "bob", True, "api", dv(x_old), dv(x))


class History:
    """A node's history as the tracker's fill reads it; what it was asked."""

    def __init__(self, records: Sequence[HistoryRecord] = (), reason: str = "") -> None:
        self.records, self.reason = list(records), reason
        self.asked: list[tuple[str, int, int]] = []

    def __call__(self, node: str, after: int, before: int) -> tuple[Sequence[HistoryRecord], str]:
        self.asked.append((node, after, before))
        return [r for r in self.records if r.revision > after], self.reason


def topics(out: list[Out]) -> list[str]:
    return [channel.topic for channel, _, _ in out]


def test_the_snapshot_then_each_change_once() -> None:
    tracker = Tracker(History())
    out = tracker.start(state(), NOW)
    assert topics(out) == ["/paramdds/snapshot"]
    assert out[0][1]["parameters"][0]["last_change"]["who"] == "alice"  # type: ignore[index]
    # the initial sync's event for what the snapshot holds: nothing
    same = MonitorEvent(
        EventKind.ADDED,
        "n",
        "v",
        dv(1.0),
        D,
        3,
        0.0,
        1,
        last_change=LastChange("alice", False, "cli", NOW + 3, 3),
    )
    assert tracker.on_event(same, NOW) == []
    out = tracker.on_event(change(4, 2.0), NOW)
    ((_, body, log_time),) = out
    assert (body["old"], body["new"], body["who"], body["revision"]) == (
        {"type": "double", "value": 1.0}, {"type": "double", "value": 2.0}, "alice", 4
    )  # fmt: skip
    assert log_time == NOW + 4  # the change's time
    assert tracker.on_event(change(4, 2.0), NOW) == []  # re-sent: nothing
    # the same value set again is a new change (a later revision)
    assert topics(tracker.on_event(change(5, 2.0, who="carol"), NOW)) == ["/paramdds/changes"]


def test_skipped_revisions_are_read_from_history_in_order() -> None:
    history = History([record(4, 1.0, 7.0), record(5, 7.0, 8.0)])
    tracker = Tracker(history)
    tracker.start(state(), NOW)
    out = tracker.on_event(change(6, 9.0), NOW)
    assert history.asked == [("n", 3, 6)]
    bodies = [b for _, b, _ in out]
    assert [(b["revision"], b["source"], b["who"]) for b in bodies] == [
        (4, "history", "bob"),
        (5, "history", "bob"),
        (6, "live", "alice"),
    ]
    assert [b["old"]["value"] for b in bodies] == [1.0, 7.0, 8.0]  # type: ignore[index]
    assert tracker.changes == 3 and tracker.gaps == 0


def test_revisions_history_lacks_are_a_gap_with_the_reason() -> None:
    tracker = Tracker(History([record(5, 1.0, 8.0)], reason="retention dropped it"))
    tracker.start(state(), NOW)
    out = tracker.on_event(change(7, 9.0), NOW)
    assert topics(out) == ["/paramdds/gaps", "/paramdds/changes", "/paramdds/gaps", "/paramdds/changes"]
    gaps = [(b["after"], b["before"], b["reason"]) for c, b, _ in out if c.topic == "/paramdds/gaps"]
    assert gaps == [(3, 5, "retention dropped it"), (5, 7, "retention dropped it")]
    no_history = Tracker(History(reason="the node keeps no history"))
    no_history.start(state(), NOW)
    out = no_history.on_event(change(9, 9.0), NOW)
    assert [(b["after"], b["before"]) for c, b, _ in out if c.topic == "/paramdds/gaps"] == [(3, 9)]
    assert no_history.gaps == 1


def test_a_live_change_history_filled_already_is_not_recorded_twice() -> None:
    # a lagging reader's take: v@6 first, then w's change of revision 5 shown late
    history = History([record(4, 1.0, 7.0), record(5, 0.0, 3.0, name="w")])
    tracker = Tracker(history)
    tracker.start(state(), NOW)
    tracker.on_event(change(6, 9.0), NOW)
    late = MonitorEvent(
        EventKind.MODIFIED, "n", "w", dv(3.0), ParameterDescriptor("w", T.DOUBLE), 6, 0.0, 1,
        last_change=LastChange("bob", True, "api", NOW + 5, 5),
    )  # fmt: skip
    assert tracker.on_event(late, NOW) == []


def test_presence_and_restarts() -> None:
    tracker = Tracker(History())
    tracker.start(state(), NOW)
    assert tracker.on_event(MonitorEvent(EventKind.ONLINE, "n"), NOW) == []  # online already
    out = tracker.on_event(MonitorEvent(EventKind.OFFLINE, "n", revision=3), NOW)
    assert [(b["event"], b["online"]) for _, b, _ in out] == [("offline", False)]
    out = tracker.on_event(MonitorEvent(EventKind.RESTARTED, "n", revision=1, incarnation=2), NOW)
    assert [b["event"] for _, b, _ in out] == ["restarted"]
    # revisions start again: revision 2 of the new incarnation is no gap
    out = tracker.on_event(change(2, 5.0), NOW)
    assert topics(out) == ["/paramdds/changes"]
    out = tracker.on_event(MonitorEvent(EventKind.DELETED, "n", "v", None, None, 3), NOW)
    assert [(b["kind"], b["new"], b["value"]) for _, b, _ in out] == [("deleted", None, None)]
    assert tracker.on_event(MonitorEvent(EventKind.DELETED, "n", "v", None, None, 3), NOW) == []
    # a node first seen after the start: its changes, no gap before its first
    assert topics(tracker.on_event(MonitorEvent(EventKind.ADDED, "m", "x", dv(1.0), D, 40), NOW)) == [
        "/paramdds/changes"
    ]
    assert tracker.nodes == 2
