"""The life of one call (paramdds.core.call): its schedule and how it fails, without any transport."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.call import (
    MAX_RESEND,
    Call,
    Failure,
    GetRequest,
    ListRequest,
    SetRequest,
    Wake,
    closed_error,
)
from paramdds.errors import OutcomeUnknownError, UnavailableError


def dds_call(*, write: bool = False, timeout: float = 5.0, started: float = 100.0) -> Call:
    return Call("n", 1, write, timeout, started, resend_after=0.2, match_poll=0.02)


def one_copy_call(*, write: bool = False, timeout: float = 5.0) -> Call:
    return Call("s/n", 1, write, timeout, 100.0, grace=0.5)


def never() -> bool:
    raise AssertionError("must not be asked")


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


def test_at_the_deadline_a_write_that_may_apply_is_outcome_unknown_without_asking() -> None:
    call = dds_call(write=True)
    call.sent(True)
    assert call.verdict(never) is Failure.OUTCOME_UNKNOWN


@pytest.mark.parametrize("write", [False, True])
def test_at_the_deadline_a_call_that_cannot_apply_is_not_seen_or_timeout(write: bool) -> None:
    call = dds_call(write=write)
    call.sent(False)
    assert call.verdict(lambda: False) is Failure.NOT_SEEN
    assert call.verdict(lambda: True) is Failure.TIMEOUT


def test_a_one_copy_transport_is_never_asked_about_presence() -> None:
    assert one_copy_call().verdict(never) is Failure.TIMEOUT
    write = one_copy_call(write=True)
    write.sent(True)
    assert write.verdict(never) is Failure.OUTCOME_UNKNOWN


def test_at_a_resend_a_gone_node_ends_a_call_unless_a_write_may_have_reached_it() -> None:
    call = dds_call()
    assert call.lost(lambda: True)
    assert not call.lost(lambda: False)
    write = dds_call(write=True)
    write.sent(True)
    assert not write.lost(never)


def test_news_is_discovery_settling_or_a_liveliness_change() -> None:
    call = dds_call()
    call.watch(None)
    assert not call.news((False, 0))  # first look, not settled
    assert not call.news((False, 0))
    assert call.news((True, 0))  # settled just now
    assert not call.news((True, 0))
    assert call.news((True, 1))  # a server's liveliness changed
    assert not call.news((True, 1))
    fresh = dds_call()
    fresh.watch(None)
    assert fresh.news((True, 0))  # settled at the first look


def test_news_does_not_end_a_write_that_may_have_reached_its_node() -> None:
    call = dds_call(write=True)
    call.watch((False, 0))
    call.sent(True)
    assert not call.news((True, 5))


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
