"""A request's deadline at the table's commit point (paramdds.core.deadline)."""

from __future__ import annotations

import time
from collections.abc import Sequence

import pytest

from paramdds.core import deadline as deadlines
from paramdds.core.results import SetOutcome, SetVeto
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterValue
from paramdds.errors import ErrorCode, ExpiredError


def P(name: str, value: object) -> Parameter:
    return Parameter(name, ParameterValue.from_python(value))


def _table() -> ParameterTable:
    t = ParameterTable("n")
    t.declare("a", 1)
    t.declare("b", "x")
    return t


def test_the_deadline_falls_before_the_end_of_the_wait() -> None:
    start = 1_000_000_000_000
    assert deadlines.deadline_for(5.0, start) == start + 4_800_000_000  # 0.2 s for the answer
    assert deadlines.deadline_for(1.0, start) == start + 900_000_000  # a tenth of a short wait
    assert deadlines.remaining(0) is None  # no deadline
    deadlines.check(0)
    deadlines.check(time.time_ns() + 10**9)


@pytest.mark.parametrize("atomic", [False, True])
def test_past_its_deadline_a_set_changes_nothing(atomic: bool) -> None:
    t = _table()
    events: list[object] = []
    t.add_change_listener(events.append)
    setter = t.set_atomically if atomic else t.set
    with deadlines.applying(time.time_ns() - 10**8), pytest.raises(ExpiredError) as raised:
        setter([P("a", 2), P("b", "y")])
    assert raised.value.code is ErrorCode.EXPIRED and "0.1" in raised.value.message
    assert (t.get("a").value, t.get("b").value, t.revision, events) == (1, "x", 2, [])
    with deadlines.applying(time.time_ns() + 10**10):  # in time
        assert setter([P("a", 2)]).results[0].successful
    assert t.get("a").value == 2


def test_the_check_comes_after_the_callbacks() -> None:
    """A callback that outlasts the deadline (a stall inside the commit path) commits nothing."""
    t = _table()

    def slow(params: list[Parameter]) -> SetVeto:
        time.sleep(0.05)
        return SetVeto(True)

    t.add_on_set_callback(slow)
    with deadlines.applying(time.time_ns() + 20_000_000), pytest.raises(ExpiredError):  # 20 ms
        t.set([P("a", 3)])
    assert t.get("a").value == 1


def test_outside_a_request_and_on_other_threads_there_is_no_deadline() -> None:
    t = _table()
    assert deadlines.current() == 0
    assert t.set([P("a", 5)]).results[0].successful  # the application's own set


def test_a_subclass_that_overrides_set_keeps_the_check() -> None:
    class Logged(ParameterTable):
        def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome:
            return super().set(params, expected_revision=expected_revision)

    t = Logged("n")
    t.declare("a", 1)
    with deadlines.applying(time.time_ns() - 1), pytest.raises(ExpiredError):
        t.set([P("a", 2)])
    assert t.get("a").value == 1
