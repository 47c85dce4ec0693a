"""Batched writes leave at once: set replies and state samples, to another process.

The server's set-reply writer and state writer batch their samples (Cyclone's writer
batching: a group's replies, a publication's samples, each one datagram per reader) and
send each batch when it is complete. A batch left unsent is not lost, but it waits: a
reply until its client resends the request (``RESEND_AFTER``, 0.2 s), state samples until
the server's next liveliness assertion (every 0.25 s). These tests fail if it waits:
their bounds are far above a batch sent at once (about a millisecond here) and far
below those timers. The server runs in another process: samples delivered within one
process never go through a batch.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from paramdds.core.values import ParameterValue
from paramdds.dds.client import RESEND_AFTER
from paramdds.dds.monitor import NodeState

from .helpers import DdsSession, ServerProc

pytestmark = pytest.mark.timeout(60)

NAMES = [f"p{i}" for i in range(10)]
NODE = {"id": "batched", "params": dict.fromkeys(NAMES, 0.5), "dynamic": {"gone": 1}}
ROUNDS = 20
LIVELINESS_TICK = 0.25  # seconds between the server's liveliness assertions (LEASE / 4)


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def test_set_replies_are_sent_when_written_not_when_the_client_resends(dds: DdsSession) -> None:
    client = dds.client()
    with ServerProc(dds.domain_id, [NODE]):
        client.wait_for_node("batched", 10.0)
        took = []
        for i in range(ROUNDS):
            start = time.monotonic()
            assert client.set("batched", {"p0": float(i)}).successful
            took.append(time.monotonic() - start)
    took.sort()
    assert took[ROUNDS // 2] < RESEND_AFTER / 4, f"median {took[ROUNDS // 2]:.3f} s: {took}"


def test_state_samples_are_sent_when_published_not_at_the_next_liveliness_tick(dds: DdsSession) -> None:
    monitor = dds.monitor()
    client = dds.client()
    with ServerProc(dds.domain_id, [NODE]):
        assert monitor.wait_complete(["batched"], timeout=10.0)
        took = []
        for i in range(ROUNDS):
            wanted = {n: float(10 * i + j) for j, n in enumerate(NAMES)}
            start = time.monotonic()
            reply = client.set("batched", wanted)
            assert reply.successful

            def arrived(
                states: dict[str, NodeState], wanted: dict[str, float] = wanted, at: int = reply.revision
            ) -> bool:
                state = states["batched"]  # every sample of the set, and the presence after them
                have = state.parameters
                return state.revision == at and all(
                    have[n][0].same_as(ParameterValue.from_python(v)) for n, v in wanted.items()
                )

            assert monitor.wait_until(arrived, timeout=5.0), f"set {i}: {monitor.snapshot()['batched']}"
            took.append(time.monotonic() - start)
        deleted = client.delete("batched", ["gone"])
        assert deleted.successful
        # a dispose goes in the same batch as the presence that gives its revision
        assert monitor.wait_until(
            lambda s: "gone" not in s["batched"].parameters and s["batched"].revision == deleted.revision,
            timeout=5.0,
        )
    # waiting for the tick would take LIVELINESS_TICK / 2 on average
    assert sum(took) / ROUNDS < LIVELINESS_TICK / 4, f"mean {sum(took) / ROUNDS:.3f} s: {sorted(took)}"
