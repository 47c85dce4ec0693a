"""A native filter lives as long as the readers of its topic, with no reference kept by the caller.

The C filter reads its table's memory for every sample delivered to a reader of the
topic, so the table must outlive the reader; once the reader and its topic are gone
it must be freed (a filter per client would otherwise leak).
"""

from __future__ import annotations

import gc
import os
import time
import weakref
from collections.abc import Iterator
from typing import Any

import pytest
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from paramdds.dds import filters
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire

from .helpers import DdsSession

pytestmark = [
    pytest.mark.timeout(60),
    pytest.mark.skipif(
        not filters.NATIVE and not os.environ.get("PARAMDDS_REQUIRE_NATIVE"),
        reason="the native filter extension is not built (CI sets PARAMDDS_REQUIRE_NATIVE=1: fails there)",
    ),
]


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def filtered_reader(participant: Any, hosted: list[str]) -> tuple[Any, weakref.ref[filters.NativeFilter]]:
    """A reader of requests for ``hosted`` nodes; the caller gets only a weak reference to the filter."""
    flt = filters.NativeFilter("nodes")
    flt.set_nodes(hosted)
    topic = filters.filtered_topic(participant, "GetParametersRequest", wire.GetParametersRequest, flt)
    reader = DataReader(participant, topic, QosProfiles.load().reader("GetParametersRequest"))
    return reader, weakref.ref(flt)


def test_the_filter_outlives_every_reference_but_the_readers_and_then_goes(dds: DdsSession) -> None:
    participant = dds.participant()
    reader, flt = filtered_reader(participant, ["mine"])
    gc.collect()
    assert flt() is not None  # held by the topic the reader holds

    topic = make_topic(participant, "GetParametersRequest", wire.GetParametersRequest)
    writer = DataWriter(participant, topic, QosProfiles.load().writer("GetParametersRequest"))
    for i, node in enumerate(["other", "mine", "/mine", "other", "mine"] * 20):
        writer.write(wire.GetParametersRequest(node_id=node, client_id=1, request_id=i + 1, names=["x"]))
    taken: list[str] = []
    deadline = time.monotonic() + 10.0
    while len(taken) < 60 and time.monotonic() < deadline:
        taken.extend(s.node_id for s in reader.take(N=100))
        time.sleep(0.01)
    gc.collect()
    taken.extend(s.node_id for s in reader.take(N=100))
    assert sorted(set(taken)) == ["/mine", "mine"] and len(taken) == 60
    live = flt()
    assert live is not None and live.counts() == (60, 40, 0)
    del live

    del reader
    gc.collect()
    assert flt() is None  # gone with the reader and its topic: nothing keeps filters forever
