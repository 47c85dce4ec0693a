"""The server's commit path: retries with NaN, assignments to late nodes, internal errors.

* A retried set is recognised by its encoded bytes: a set carrying NaN (which is
  not ``==`` to itself) is applied once, not twice.
* A node added after ``start()`` still receives the retained assignments made for it.
* A failure inside the server is reported as INTERNAL (not as INVALID_VALUE, which
  means the node refused the value), and the server keeps serving.
* A client that meets a code it does not know (from a newer node) raises a generic
  error carrying it, and reports it per name, instead of failing with ValueError.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from collections.abc import Sequence

import pytest
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from paramdds.core.results import ChangeSet, SetOutcome
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter
from paramdds.dds.assign import Assigner
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.errors import ErrorCode, RemoteError

from .conftest import DDS, wait
from .rawwire import RawPeer

_ids = itertools.count(1)


def _double_set(node: str, request_id: int, value: float) -> wire.SetParametersRequest:
    p = wire.Parameter("d", wire.ParameterValue(type=3, double_value=value))
    return wire.SetParametersRequest(node_id=node, client_id=0xAB, request_id=request_id, parameters=[p])


@pytest.mark.timeout(30)
def test_a_retried_set_carrying_nan_is_applied_once(domain_id: int, dds: DDS) -> None:
    table = ParameterTable("nan")
    table.declare("d", 1.0)
    commits: list[ChangeSet] = []
    table.add_change_listener(commits.append)
    dds.server(domain_id, table)
    peer = RawPeer(dds.participant(domain_id))
    # positive control: a retry of a plain value is answered from the cache, applied once
    plain = _double_set("nan", next(_ids), 2.0)
    assert peer.call(plain).results[0].successful
    peer.send(plain)
    assert len(peer.replies(plain, count=2)) == 2
    assert len(commits) == 1

    request = _double_set("nan", next(_ids), math.nan)
    first = peer.call(request)
    assert first.results[0].successful and math.isnan(table.get("d").value)  # type: ignore[arg-type]
    peer.send(request)  # the retry: the same sample
    replies = peer.replies(request, count=2)
    assert len(replies) == 2 and replies[1].revision == first.revision
    time.sleep(0.1)
    assert len(commits) == 2, "a retried NaN set was applied a second time"


@pytest.mark.timeout(30)
def test_a_node_added_after_start_receives_its_retained_assignments(domain_id: int, dds: DDS) -> None:
    participant = dds.participant(domain_id)
    early = ParameterTable("early")
    early.declare("speed", 1.0)
    server = dds.server(domain_id, early)
    assigner = dds.own(Assigner(participant))
    assigner.assign("early", {"speed": 2.0})
    assigner.assign("late", {"speed": 3.0})
    assert wait(lambda: early.get("speed").value == 2.0, 5.0)  # positive control: a node hosted at start
    late = ParameterTable("late")
    late.declare("speed", 1.0)
    server.add_node(late)
    assert wait(lambda: late.get("speed").value == 3.0, 5.0), (
        "a node added after start() missed its assignment"
    )


class _Broken(ParameterTable):
    """A table with a bug: a set of ``boom`` raises something that is not a ParamddsError."""

    def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome:
        if any(p.name == "boom" for p in params):
            raise RuntimeError("a bug")
        return super().set(params, expected_revision=expected_revision)


@pytest.mark.timeout(30)
def test_an_internal_failure_is_reported_as_internal(domain_id: int, dds: DDS) -> None:
    table = _Broken("broken", allow_undeclared=True)
    dds.server(domain_id, table)
    client = dds.client(domain_id, timeout=5.0)
    client.wait_for_node("broken")
    assert client.set("broken", {"fine": 1}).successful  # positive control
    with pytest.raises(Exception) as caught:
        client.set("broken", {"boom": 1})
    assert getattr(caught.value, "code", None) is ErrorCode.INTERNAL
    assert client.set("broken", {"fine": 2}).successful  # still serving


@pytest.mark.timeout(30)
def test_a_code_this_client_does_not_know_is_a_generic_error_carrying_it(domain_id: int, dds: DDS) -> None:
    # a "newer node": a plain cyclonedds program that announces itself and answers every
    # get with a per-name code and, for one name, a whole-request code this version lacks
    participant = dds.participant(domain_id)
    qos = QosProfiles.load()
    state = DataWriter(
        participant,
        make_topic(participant, "ParameterEvents", wire.ParameterEvent),
        qos.writer("ParameterEvents"),
    )
    state.write(wire.ParameterEvent(node_id="future", name="", kind=wire.EVENT_PRESENCE, parameter_count=1))
    requests = DataReader(
        participant,
        make_topic(participant, "GetParametersRequest", wire.GetParametersRequest),
        qos.reader("GetParametersRequest"),
    )
    replies = DataWriter(
        participant,
        make_topic(participant, "GetParametersResponse", wire.GetParametersResponse),
        qos.writer("GetParametersResponse"),
    )
    stop = threading.Event()

    def answer() -> None:
        while not stop.is_set():
            for r in requests.take(N=16):
                if not r.sample_info.valid_data:
                    continue
                reply = wire.GetParametersResponse(
                    node_id="future", client_id=r.client_id, request_id=r.request_id
                )
                if r.names == ["whole"]:
                    reply.code, reply.reason = "FROM_THE_FUTURE", "a newer refusal"
                else:
                    reply.results = [
                        wire.GetParameterResult(name=n, code="ALSO_NEW", reason="new per-name refusal")
                        for n in r.names
                    ]
                replies.write(reply)
            time.sleep(0.005)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    try:
        client = dds.client(domain_id, timeout=5.0)
        client.wait_for_node("future")
        got = client.get("future", ["x"])
        assert got.results[0].code is ErrorCode.UNKNOWN and got.results[0].value is None
        with pytest.raises(RemoteError) as caught:
            client.get("future", ["whole"])
        assert caught.value.code is ErrorCode.UNKNOWN and caught.value.remote_code == "FROM_THE_FUTURE"
        assert "a newer refusal" in caught.value.message
    finally:
        stop.set()
        thread.join(5)
