"""Retained assignments: values published for a node before it starts reach it when it starts
(validated like any set), and never ride the interactive request/reply path."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from cyclonedds.sub import DataReader

from paramdds.dds.assign import Assigner
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire

from .helpers import DdsSession, ServerProc, wait_until

pytestmark = pytest.mark.timeout(60)

NODE = {
    "id": "late",
    "ranged": {"speed": [5, 0, 10], "limit": [3, 0, 10]},
    "params": {"label": "default"},
}


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def _value(monitor: object, name: str) -> object:
    state = monitor.snapshot()["late"]  # type: ignore[attr-defined]
    return state.parameters[name][0].value


@pytest.mark.slow
def test_assignment_reaches_a_node_started_later_validated(dds: DdsSession) -> None:
    assigner = Assigner(dds.participant("paramdds-test-assigner"))
    assigner.assign("/late", {"speed": 7, "limit": 99, "label": "assigned"})  # limit is out of range

    monitor = dds.monitor()
    client = dds.client()
    with ServerProc(dds.domain_id, [NODE]):
        assert monitor.wait_until(
            lambda s: "late" in s and s["late"].complete and s["late"].parameters["speed"][0].value == 7,
            timeout=5.0,
        )
        got = client.get("late", ["speed", "limit", "label"])
        # the valid values applied, the invalid one refused: its default stays
        assert {n: v.value for n, v in got.values().items()} == {"speed": 7, "limit": 3, "label": "assigned"}

        # an interactive set later wins over the assignment, and is not undone by it
        assert client.set("late", {"speed": 8}).successful
        assert client.get_value("late", "speed").value == 8

        # a changed assignment is applied while the node runs
        assigner.assign("late", {"limit": 4})
        assert monitor.wait_until(lambda s: s["late"].parameters["limit"][0].value == 4, timeout=5.0)
        assert client.get_value("late", "speed").value == 8  # the new assignment replaced the old one

    # the node restarts: defaults, then the retained assignment (still held by the assigner)
    with ServerProc(dds.domain_id, [NODE]) as restarted:
        assert monitor.wait_until(
            lambda s: s["late"].online and s["late"].pid == restarted.pid and s["late"].complete,
            timeout=5.0,
        )
        assert monitor.wait_until(lambda s: s["late"].parameters["limit"][0].value == 4, timeout=5.0)

        def client_sees_restart() -> bool:
            info = client.node_info("late")
            return info is not None and info.online and info.pid == restarted.pid

        assert wait_until(client_sees_restart, timeout=5.0)
        got = client.get("late", ["speed", "limit", "label"])
        assert {n: v.value for n, v in got.values().items()} == {"speed": 5, "limit": 4, "label": "default"}


def test_an_answer_is_kept_for_an_assigner_that_matches_late_never_a_reply(dds: DdsSession) -> None:
    """Each side discovers the other's endpoints on its own, so a node may answer an assignment
    before the assigner's reader has matched its writer: the answer is kept for that reader (a
    volatile one was lost, and ``paramdds assign`` waited for an answer that never came).
    Interactive replies are never kept: a client that reuses request ids gets no old reply."""
    assigner = Assigner(dds.participant("paramdds-test-assigner"))  # no reader of answers
    assigner.assign("late", {"speed": 6, "limit": 99})  # limit is out of range
    with ServerProc(dds.domain_id, [NODE]):
        first = dds.client()
        first.wait_for_node("late", timeout=5.0)
        # the retained assignment reaches the node once discovery matches the assigner: wait for it,
        # or it may land between the second client's set and get below (a revision apart)
        assert wait_until(lambda: first.get_value("late", "speed").value == 6, timeout=5.0)
        for i in range(1, 6):
            assert first.set("late", {"label": f"run1-{i}"}).successful
        first.close()

        dp = dds.participant()
        answers = DataReader(
            dp,
            make_topic(dp, "SetParametersResponse", wire.SetParametersResponse),
            QosProfiles.load().answer_reader(),  # matches after the answer: gets it all the same
        )
        second = dds.client(dp)
        second.wait_for_node("late", timeout=5.0)
        reply = second.set("late", {"limit": 9})  # request id 1 again
        assert [(r.name, r.successful) for r in reply.results] == [("limit", True)]
        got = second.get("late", ["speed", "limit", "label"])
        assert got.revision == reply.revision
        assert {n: v.value for n, v in got.values().items()} == {"speed": 6, "limit": 9, "label": "run1-5"}
        kept: list[object] = []
        assert wait_until(lambda: bool(kept.extend(answers.take(N=100))) or kept != [], timeout=5.0)
        wait_until(lambda: False, 0.3)  # and nothing more
        kept.extend(answers.take(N=100))
        outcomes = [
            (s.client_id, [(r.name, r.successful) for r in s.results])  # type: ignore[attr-defined]
            for s in kept
            if s.sample_info.valid_data  # type: ignore[attr-defined]
        ]
        assert outcomes == [(assigner.client_id, [("speed", True), ("limit", False)])]
        assert assigner.client_id not in {first.client_id, second.client_id}
