"""A compare-and-set refused by a restarted node after more than one copy went out is of unknown
outcome: an earlier copy may have landed in the server life it expected (found by the soak).
A compare-and-set refused by the one life that got every copy is a true refusal (CI's Fast DDS
peer, whose CLI call went out twice, was told "outcome unknown" for a wrong expectation)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from types import SimpleNamespace

import pytest

from paramdds.core.call import Call
from paramdds.core.revision import Revision
from paramdds.core.table import ParameterTable
from paramdds.dds import client as client_module
from paramdds.dds.client_protocol import PendingCall
from paramdds.dds.client_transport import _refused_by_a_later_life
from paramdds.errors import ErrorCode

from .helpers import DdsSession

EXPECTED, LATER = 0x3314B8175C09313F, 0x31C6726614C9038E


def pending(
    copies: int, expected_incarnation: int = EXPECTED, kind: str = "SetParametersRequest", serving: int = 0
) -> PendingCall:
    write = kind == "SetParametersRequest"
    call = Call("soak_n11", 1, write, 5.0, 100.0, resend_after=0.2, match_poll=0.02)
    for i in range(copies):
        call.sent(True, 100.0 + i)
    message = SimpleNamespace(expected_incarnation=expected_incarnation)
    the_pending = PendingCall(call, kind, message)
    the_pending.serving_life = serving  # the life serving the node when the first copy went out
    return the_pending


def unseen() -> int:
    return 0  # no life this client can vouch for


def seen(life: int) -> Callable[[], int]:
    return lambda: life


def reply(incarnation: int, *successful: bool, code: str = "") -> SimpleNamespace:
    results = [SimpleNamespace(successful=s) for s in successful]
    return SimpleNamespace(incarnation=incarnation, code=code, results=results)


def test_a_refusal_from_a_later_life_after_a_resend_is_not_believed() -> None:
    assert _refused_by_a_later_life(pending(2), reply(LATER, False, False), unseen)
    assert _refused_by_a_later_life(pending(3), reply(LATER, code="CONFLICT"), unseen)
    # the life serving at the first copy was the one expected, a later one refused
    assert _refused_by_a_later_life(pending(2, serving=EXPECTED), reply(LATER, False), seen(LATER))


@pytest.mark.parametrize(
    ("the_pending", "the_reply"),
    [
        (pending(1), reply(LATER, False)),  # one copy: it went to the later life alone
        (pending(2), reply(EXPECTED, False)),  # refused by the life it expected: true
        (pending(2), reply(LATER, True, True)),  # applied by the later life: true
        (pending(2, expected_incarnation=0), reply(LATER, False)),  # no life expected
        (pending(2, kind="GetParametersRequest"), reply(LATER, False)),  # not a write
        (pending(2, serving=LATER), reply(LATER, False)),  # every copy went to the life that refused
    ],
)
def test_every_other_answer_is_taken_as_it_is(the_pending: PendingCall, the_reply: SimpleNamespace) -> None:
    assert not _refused_by_a_later_life(the_pending, the_reply, unseen)


def test_a_refusal_by_the_one_life_this_client_ever_saw_is_true() -> None:
    """No presence when the first copy went out: the life seen since, with no gap, counts."""
    assert not _refused_by_a_later_life(pending(2), reply(LATER, False), seen(LATER))
    assert _refused_by_a_later_life(pending(2), reply(LATER, False), seen(0))  # a gap, or none online


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


@pytest.mark.timeout(60)
def test_a_wrong_expectation_sent_many_times_is_refused_as_a_conflict(
    dds: DdsSession, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Real DDS: copies every 0.1 ms (the reply takes longer), so each set goes out more than
    once. A wrong incarnation is a CONFLICT (never "outcome unknown"), the right one applies once."""
    table = ParameterTable("twice")
    table.declare("count", 3)
    server = dds.server(table)
    client = dds.client()
    at = client.wait_for_node("twice", timeout=5.0).at
    monkeypatch.setattr(client_module, "RESEND_AFTER", 0.0001)
    wrong = Revision(at.incarnation ^ 1, at.revision)
    for _ in range(5):
        refused = client.set("twice", {"count": 5}, if_revision=wrong)
        assert [(r.successful, r.code) for r in refused.results] == [(False, ErrorCode.CONFLICT)]
    applied = client.set("twice", {"count": 4}, if_revision=at)
    assert applied.successful and applied.at == Revision(server.incarnation("twice"), at.revision + 1)
    assert table.get("count").value == 4
