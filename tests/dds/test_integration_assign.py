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


def test_assignment_never_produces_replies_or_stale_replies(dds: DdsSession) -> None:
    assigner = Assigner(dds.participant("paramdds-test-assigner"))
    assigner.assign("late", {"speed": 6})
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
        history = DataReader(
            dp,
            make_topic(dp, "SetParametersResponse", wire.SetParametersResponse),
            QosProfiles.load().assignment_reader(),  # asks for history: there must be none
        )
        second = dds.client(dp)
        second.wait_for_node("late", timeout=5.0)
        reply = second.set("late", {"limit": 9})  # request id 1 again
        assert [(r.name, r.successful) for r in reply.results] == [("limit", True)]
        got = second.get("late", ["speed", "limit", "label"])
        assert got.revision == reply.revision
        assert {n: v.value for n, v in got.values().items()} == {"speed": 6, "limit": 9, "label": "run1-5"}
        assert [s.client_id for s in history.take(N=100) if s.sample_info.valid_data] == []
        assert assigner.client_id not in {first.client_id, second.client_id}
