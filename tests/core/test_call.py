"""The life of one call (paramdds.core.call): its schedule and how it fails, without any transport."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.call import (
    IN_FLIGHT,
    MAX_RESEND,
    Call,
    Failure,
    GetRequest,
    ListRequest,
    Mark,
    Presence,
    SetRequest,
    Wake,
    closed_error,
)
from paramdds.errors import OutcomeUnknownError, UnavailableError


def dds_call(*, write: bool = False, timeout: float = 5.0, started: float = 100.0) -> Call:
    return Call("n", 1, write, timeout, started, resend_after=0.2, match_poll=0.02)


def one_copy_call(*, write: bool = False, timeout: float = 5.0) -> Call:
    return Call("s/n", 1, write, timeout, 100.0, grace=0.5)


def never() -> Presence:
    raise AssertionError("must not be asked")


def always(presence: Presence) -> Callable[[], Presence]:
    return lambda: presence


# -- requests -------------------------------------------------------------------------------


def test_only_a_set_is_a_write() -> None:
    assert not ListRequest("n", (), 0).write
    assert not GetRequest("n", ("x",), False).write
    assert SetRequest("n", {"x": 1}, False, None).write


# -- the schedule ---------------------------------------------------------------------------


def test_a_call_that_resends_wakes_to_poll_then_to_resend_with_backoff() -> None:
    call = dds_call()
    assert call.wait(100.0) == pytest.approx(0.02)  # the match poll comes first
    assert call.wake(100.02) is Wake.POLL
    assert call.wait(100.19) == pytest.approx(0.01)  # the resend timer is nearer than the poll
    assert call.wake(100.2) is Wake.RESEND
    assert call.wake(100.21) is Wake.POLL
    assert call.wake(100.59) is Wake.POLL
    assert call.wake(100.61) is Wake.RESEND  # 0.4 s after the first resend
    assert call.wake(101.42) is Wake.RESEND  # 0.8 s after that
    assert call.wake(102.41) is Wake.POLL
    assert call.wake(102.43) is Wake.RESEND  # 1 s (MAX_RESEND) after that
    assert call.wake(103.44) is Wake.RESEND


@given(st.lists(st.floats(min_value=0.0, max_value=3.0), min_size=1, max_size=40))
def test_resends_never_come_closer_than_the_first_gap_nor_further_than_the_cap(gaps: list[float]) -> None:
    call = dds_call(timeout=1000.0)
    now, last = 100.0, 100.0
    for gap in gaps:  # woken early (a reply that was not ours, a poll) or when the call said
        now += min(gap, call.wait(now))
        if call.wake(now) is Wake.RESEND:
            assert 0.2 - 1e-9 <= now - last <= MAX_RESEND + 1e-9
            last = now
        assert call.wait(now) <= call.match_poll + 1e-9


@given(st.floats(min_value=0.0, max_value=20.0))
def test_a_call_never_waits_past_its_deadline(now_offset: float) -> None:
    call = dds_call(timeout=5.0)
    now = 100.0 + now_offset
    assert 0.0 <= call.wait(now) <= max(0.0, call.deadline - now) + 1e-9
    assert call.expired(now) == (now >= 105.0)


def test_a_transport_that_bounds_its_copy_gets_its_grace_and_is_never_woken_early() -> None:
    call = one_copy_call(timeout=3.0)
    assert call.deadline == pytest.approx(103.5)
    assert call.wait(100.0) == pytest.approx(3.5)
    assert call.wake(102.0) is Wake.POLL
    assert not call.resends


# -- how a call fails -----------------------------------------------------------------------


def test_a_write_reaches_its_node_only_once_a_copy_went_to_a_peer() -> None:
    call = dds_call(write=True)
    assert not call.may_apply
    call.sent(False)
    assert not call.may_apply
    call.sent(True)
    call.sent(False)  # a later copy without a peer does not unsend the first
    assert call.may_apply
    read = dds_call()
    read.sent(True)
    assert not read.may_apply  # a read is never applied


def test_at_the_deadline_a_write_that_reached_an_announced_node_is_outcome_unknown_without_asking() -> None:
    call = dds_call(write=True)
    call.sent(True, 100.0)
    call.saw(Presence.ONLINE)
    assert call.verdict(never, 105.0) is Failure.OUTCOME_UNKNOWN


@pytest.mark.parametrize("write", [False, True])
def test_at_the_deadline_a_call_that_cannot_apply_is_not_seen_or_timeout(write: bool) -> None:
    call = dds_call(write=write)
    call.sent(False, 100.0)
    assert call.verdict(always(Presence.OFFLINE), 105.0) is Failure.NOT_SEEN
    assert call.verdict(always(Presence.UNKNOWN), 105.0) is Failure.NOT_SEEN
    assert call.verdict(always(Presence.ONLINE), 105.0) is Failure.TIMEOUT


def test_a_one_copy_transport_is_never_asked_about_presence() -> None:
    assert one_copy_call().verdict(never, 105.0) is Failure.TIMEOUT
    write = one_copy_call(write=True)
    write.sent(True)
    assert write.verdict(never, 105.0) is Failure.OUTCOME_UNKNOWN


@pytest.mark.parametrize("gone", [Presence.OFFLINE, Presence.ABSENT])
def test_at_a_look_a_gone_node_ends_a_call_that_cannot_apply(gone: Presence) -> None:
    call = dds_call()
    call.watch(Mark(True, 0))
    assert call.lost(always(gone), 100.2)
    assert not call.lost(always(Presence.ONLINE), 100.2)
    assert not call.lost(always(Presence.UNKNOWN), 100.2)
    unsent = dds_call(write=True)
    unsent.sent(False, 100.0)
    assert unsent.lost(always(gone), 100.2)


def test_a_write_to_a_node_that_was_announced_is_never_lost_once_a_peer_took_it() -> None:
    for announced in (Presence.ONLINE, Presence.OFFLINE):
        write = dds_call(write=True)
        write.watch(Mark(True, 0))
        write.sent(True, 100.0)
        assert not write.lost(always(announced), 100.2)
        assert not write.lost(never, 103.0)  # offline may be a stalled node: it may still apply it
        assert write.verdict(never, 105.0) is Failure.OUTCOME_UNKNOWN
        assert not write.news(Mark(True, 1))


# -- sure never to land -----------------------------------------------------------------------


def test_a_write_no_server_announced_holds_its_copies_then_fails_not_seen() -> None:
    write = dds_call(write=True)
    write.watch(Mark(False, 0))
    write.sent(True, 100.0)
    write.sent(True, 100.2)  # the first resend
    assert not write.lost(always(Presence.UNKNOWN), 100.3)  # discovery goes on: it may appear
    assert not write.holding
    assert write.news(Mark(True, 0))  # settled: look (a write that may apply looks too)
    assert not write.lost(always(Presence.ABSENT), 100.5)  # the last copy may still be on its way
    assert write.holding  # so it sends no more copies
    assert not write.lost(always(Presence.ABSENT), 100.2 + IN_FLIGHT - 0.01)
    assert write.lost(always(Presence.ABSENT), 100.2 + IN_FLIGHT)


def test_a_held_write_whose_node_appears_meanwhile_goes_on_and_is_never_lost() -> None:
    write = dds_call(write=True)
    write.watch(Mark(True, 0))
    write.sent(True, 100.0)
    assert not write.lost(always(Presence.ABSENT), 100.1)
    assert write.holding
    assert not write.lost(always(Presence.ONLINE), 100.2)  # a server started hosting it
    assert not write.holding and write.announced
    assert not write.lost(never, 101.0)
    assert write.verdict(never, 105.0) is Failure.OUTCOME_UNKNOWN


def test_absence_is_not_sure_while_a_server_was_excused_as_dead_before_it_told_its_nodes() -> None:
    write = dds_call(write=True)  # a stopped server that took the copy may resume and apply it
    write.watch(Mark(True, 0, sure=False))
    write.sent(True, 100.0)
    assert not write.lost(always(Presence.ABSENT), 101.0)
    assert not write.holding
    assert write.verdict(always(Presence.ABSENT), 105.0) is Failure.OUTCOME_UNKNOWN
    unwatched = dds_call(write=True)  # no discovery yet: nothing is sure
    unwatched.sent(True, 100.0)
    assert not unwatched.lost(always(Presence.ABSENT), 101.0)


def test_a_copy_sent_at_an_unknown_time_is_never_taken_as_landed_nowhere() -> None:
    write = dds_call(write=True)
    write.watch(Mark(True, 0))
    write.sent(True)
    assert not write.lost(always(Presence.ABSENT), 1e9)
    assert write.holding


def test_at_the_deadline_a_write_sure_never_to_land_is_not_seen() -> None:
    write = dds_call(write=True)
    write.watch(Mark(True, 0))
    write.sent(True, 100.0)
    assert write.verdict(always(Presence.ABSENT), 105.0) is Failure.NOT_SEEN
    recent = dds_call(write=True)
    recent.watch(Mark(True, 0))
    recent.sent(True, 104.9)
    assert recent.verdict(always(Presence.ABSENT), 105.0) is Failure.OUTCOME_UNKNOWN


@given(
    st.lists(
        st.tuples(st.sampled_from(list(Presence)), st.booleans(), st.floats(min_value=0.0, max_value=0.4)),
        min_size=1,
        max_size=30,
    )
)
def test_lost_only_unannounced_sure_absent_and_quiet(looks: list[tuple[Presence, bool, float]]) -> None:
    """Whatever the looks: a write that a peer took fails NOT_SEEN only if no look ever saw its
    node announced, the look that ends it is sure and absent, and its last copy is old enough."""
    write = dds_call(write=True, timeout=1000.0)
    write.sent(True, 100.0)
    now, last_copy, announced = 100.0, 100.0, False
    for presence, sure, gap in looks:  # (what the look finds, whether discovery is sure, time since)
        now += gap
        write.watch(Mark(True, 0, sure=sure))
        if not write.holding:
            write.sent(True, now)
            last_copy = now
        lost = write.lost(always(presence), now)
        announced = announced or presence in (Presence.ONLINE, Presence.OFFLINE)
        if lost:
            assert not announced and sure and presence is Presence.ABSENT
            assert now - last_copy >= IN_FLIGHT
            return


def test_news_is_discovery_settling_or_a_liveliness_change() -> None:
    call = dds_call()
    call.watch(None)
    assert not call.news(Mark(False, 0))  # first look, not settled
    assert not call.news(Mark(False, 0))
    assert call.news(Mark(True, 0))  # settled just now
    assert not call.news(Mark(True, 0))
    assert call.news(Mark(True, 1))  # a server's liveliness changed
    assert not call.news(Mark(True, 1))
    fresh = dds_call()
    fresh.watch(None)
    assert fresh.news(Mark(True, 0))  # settled at the first look


def test_news_does_not_end_a_write_that_may_have_reached_its_announced_node() -> None:
    call = dds_call(write=True)
    call.watch(Mark(False, 0))
    call.sent(True)
    call.saw(Presence.ONLINE)
    assert not call.news(Mark(True, 5))


def test_a_copy_that_ended_without_an_answer() -> None:
    early = one_copy_call(timeout=10.0)
    assert early.unanswered(1.0) is Failure.NO_ROUTE  # the route went
    assert early.unanswered(9.5) is Failure.TIMEOUT
    write = one_copy_call(write=True, timeout=10.0)
    write.sent(True)
    assert write.unanswered(1.0) is Failure.OUTCOME_UNKNOWN


def test_closing_the_client_fails_a_call_by_what_it_may_have_done() -> None:
    call = dds_call()
    assert call.closed() is Failure.CLOSED
    assert isinstance(closed_error(call), UnavailableError)
    write = dds_call(write=True)
    write.sent(True)
    assert write.closed() is Failure.OUTCOME_UNKNOWN
    error = closed_error(write)
    assert isinstance(error, OutcomeUnknownError) and "'n'" in str(error)


def test_waited_counts_from_the_start() -> None:
    assert dds_call(started=10.0).waited(12.5) == pytest.approx(2.5)
