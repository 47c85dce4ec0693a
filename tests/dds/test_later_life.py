"""A compare-and-set refused by a restarted node after more than one copy went out is of unknown
outcome: an earlier copy may have landed in the server life it expected (found by the soak).
A compare-and-set refused by the one life that got every copy is a true refusal (CI's Fast DDS
peer, whose CLI call went out twice, was told "outcome unknown" for a wrong expectation), also
when the refusal comes before the node's presence (the same peer, again)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from types import SimpleNamespace
from typing import Any

import pytest
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from paramdds.core.call import Call
from paramdds.core.revision import Revision
from paramdds.core.table import ParameterTable
from paramdds.dds import client as client_module
from paramdds.dds.client_protocol import PendingCall
from paramdds.dds.client_transport import _refused_by_a_later_life
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.errors import ErrorCode, OutcomeUnknownError

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
    # no presence of the node held yet: undecided (the client waits for it)
    assert _refused_by_a_later_life(pending(2), reply(LATER, False), lambda: None) is None


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


class LatePresence:
    """A node on the wire whose refusal comes before its presence (as a Fast DDS server's can,
    to a one-shot client that makes its presence reader with the first copy): every copy of a
    set but the first is refused CONFLICT by life ``LATER``, and the presence of that life is
    published ``after`` seconds past the first request (None: never)."""

    def __init__(self, participant: Any, after: float | None) -> None:
        qos = QosProfiles.load()

        def endpoint(kind: Any, name: str) -> Any:
            topic = make_topic(participant, name, wire.TOPICS[name])
            return kind(participant, topic, (qos.reader if kind is DataReader else qos.writer)(name))

        self.requests = endpoint(DataReader, "SetParametersRequest")
        self.replies = endpoint(DataWriter, "SetParametersResponse")
        self.state = endpoint(DataWriter, "ParameterEvents")
        self.after, self.copies = after, 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        first = None
        while not self._stop.wait(0.005):
            for request in self.requests.take(N=64):
                if not request.sample_info.valid_data:
                    continue
                first = first or time.monotonic()
                self.copies += 1
                if self.copies == 1:
                    continue  # its reply lost: the client sends a copy again
                refused = [
                    wire.SetParameterResult(name=p.name, successful=False, reason="stale", code="CONFLICT")
                    for p in request.parameters
                ]
                self.replies.write(
                    wire.SetParametersResponse(
                        node_id=request.node_id,
                        client_id=request.client_id,
                        request_id=request.request_id,
                        revision=7,
                        results=refused,
                        incarnation=LATER,
                    )
                )
            if first is not None and self.after is not None and time.monotonic() - first >= self.after:
                self.after = None
                presence = wire.ParameterEvent(node_id="late", name="", kind=wire.EVENT_PRESENCE)
                presence.revision, presence.parameter_count, presence.incarnation = 7, 1, LATER
                self.state.write(presence)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


@pytest.mark.timeout(60)
@pytest.mark.parametrize("after", [0.3, None])
def test_a_refusal_before_its_nodes_presence_waits_for_it(
    dds: DdsSession, monkeypatch: pytest.MonkeyPatch, after: float | None
) -> None:
    """Real DDS, a one-shot client (as the CLI's), each set sent more than once, refused by a
    life this client holds no presence of yet. The presence that comes 0.3 s later shows that
    life alone: a CONFLICT. With no presence by the call's deadline: outcome unknown."""
    node = LatePresence(dds.participant("paramdds-test-late"), after)
    try:
        monkeypatch.setattr(client_module, "RESEND_AFTER", 0.01)
        client = dds.client(timeout=2.0, one_shot=True)
        wrong = Revision(EXPECTED, 7)
        if after is None:
            with pytest.raises(OutcomeUnknownError, match="restarted while the request was being sent"):
                client.set("late", {"count": 5}, if_revision=wrong)
        else:
            refused = client.set("late", {"count": 5}, if_revision=wrong)
            assert [(r.successful, r.code) for r in refused.results] == [(False, ErrorCode.CONFLICT)]
            assert refused.at == Revision(LATER, 7)
        assert node.copies > 1  # the case at hand: more than one copy went out
    finally:
        node.close()
