"""Many node ids in one server process: still exactly seven topics, each node answers its own
requests. Topics are counted by Cyclone's discovery data (DCPSTopic with topic discovery
enabled, and DCPSPublication / DCPSSubscription), not by asking our own code."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from typing import Any

import pytest
from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
    BuiltinTopicDcpsTopic,
)

from paramdds.dds.client import AsyncParameterClient
from paramdds.dds.wire import types as wire

from .helpers import DdsSession, ServerProc, wait_until

pytestmark = pytest.mark.timeout(60)

NODES = [f"robot{i:03}" for i in range(200)]
SEVEN = set(wire.TOPICS)


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id, topic_discovery=True) as session:
        yield session


def _user_topics(reader: Any, into: set[str]) -> set[str]:
    for s in reader.take(N=500):
        if s.sample_info.valid_data and not s.topic_name.startswith("DCPS"):
            into.add(s.topic_name)
    return into


@pytest.mark.slow
def test_200_nodes_in_one_process_use_seven_topics_and_answer_their_own_requests(dds: DdsSession) -> None:
    nodes = [{"id": n, "params": {"whoami": n, "index": i}} for i, n in enumerate(NODES)]
    with ServerProc(dds.domain_id, nodes, topic_discovery=True):
        monitor = dds.monitor()
        sync = dds.client(timeout=10.0)
        assert monitor.wait_complete(NODES, timeout=10.0)
        assert all(s.online for s in monitor.snapshot().values())
        assert wait_until(lambda: [n.node for n in sync.nodes() if n.online] == NODES, timeout=5.0)
        assert all(n.parameters == 2 for n in sync.nodes())

        client = AsyncParameterClient(sync)

        async def ask_all() -> list[Any]:
            return await asyncio.gather(*(client.get(n, ["whoami", "index"]) for n in NODES))

        replies = asyncio.run(ask_all())
        for i, (node, reply) in enumerate(zip(NODES, replies, strict=True)):
            assert reply.node == node
            assert {k: v.value for k, v in reply.values().items()} == {"whoami": node, "index": i}

        async def set_all() -> list[Any]:
            return await asyncio.gather(*(client.set(n, {"index": -i}) for i, n in enumerate(NODES)))

        assert all(r.successful for r in asyncio.run(set_all()))
        assert sync.get_value("robot007", "index").value == -7
        assert sync.get_value("robot199", "index").value == -199

        # what the whole system (server process + this process) created, as discovery sees it
        dp = dds.participant()
        topics: set[str] = set()
        endpoints: set[str] = set()
        topic_reader = BuiltinDataReader(dp, BuiltinTopicDcpsTopic)
        pub_reader = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
        sub_reader = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)

        def seen_all() -> bool:
            _user_topics(topic_reader, topics)
            _user_topics(pub_reader, endpoints)
            _user_topics(sub_reader, endpoints)
            return topics >= SEVEN and endpoints >= SEVEN

        assert wait_until(seen_all, timeout=5.0), (sorted(topics), sorted(endpoints))
        # one more round after everything is known, so a late eighth topic would show
        assert sync.get_value("robot100", "whoami").value == "robot100"
        _user_topics(topic_reader, topics)
        assert topics == SEVEN
        assert endpoints == SEVEN
