"""A compare-and-set refused by a restarted node after more than one copy went out is of unknown
outcome: an earlier copy may have landed in the server life it expected (found by the soak)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from paramdds.core.call import Call
from paramdds.dds.client_protocol import PendingCall
from paramdds.dds.client_transport import _refused_by_a_later_life

EXPECTED, LATER = 0x3314B8175C09313F, 0x31C6726614C9038E


def pending(
    copies: int, expected_incarnation: int = EXPECTED, kind: str = "SetParametersRequest"
) -> PendingCall:
    write = kind == "SetParametersRequest"
    call = Call("soak_n11", 1, write, 5.0, 100.0, resend_after=0.2, match_poll=0.02)
    for i in range(copies):
        call.sent(True, 100.0 + i)
    message = SimpleNamespace(expected_incarnation=expected_incarnation)
    return PendingCall(call, kind, message)


def reply(incarnation: int, *successful: bool, code: str = "") -> SimpleNamespace:
    results = [SimpleNamespace(successful=s) for s in successful]
    return SimpleNamespace(incarnation=incarnation, code=code, results=results)


def test_a_refusal_from_a_later_life_after_a_resend_is_not_believed() -> None:
    assert _refused_by_a_later_life(pending(2), reply(LATER, False, False))
    assert _refused_by_a_later_life(pending(3), reply(LATER, code="CONFLICT"))


@pytest.mark.parametrize(
    ("the_pending", "the_reply"),
    [
        (pending(1), reply(LATER, False)),  # one copy: it went to the later life alone
        (pending(2), reply(EXPECTED, False)),  # refused by the life it expected: true
        (pending(2), reply(LATER, True, True)),  # applied by the later life: true
        (pending(2, expected_incarnation=0), reply(LATER, False)),  # no life expected
        (pending(2, kind="GetParametersRequest"), reply(LATER, False)),  # not a write
    ],
)
def test_every_other_answer_is_taken_as_it_is(the_pending: PendingCall, the_reply: SimpleNamespace) -> None:
    assert not _refused_by_a_later_life(the_pending, the_reply)
