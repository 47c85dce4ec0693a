"""Validation, atomicity and no silent truncation over the wire (traps 4 and 5 of docs/wire.md),
and bad requests written with a raw Cyclone writer."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from paramdds.core.descriptors import IntegerRange, ParameterDescriptor
from paramdds.core.limits import MAX_PARAMETERS_PER_REQUEST, MAX_VALUE_BYTES
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterValue
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.errors import ErrorCode, InvalidNameError, TooLargeError

from .helpers import DdsSession, wait_until

pytestmark = pytest.mark.timeout(60)

NODE = "strict"


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def strict_table() -> ParameterTable:
    table = ParameterTable(NODE)
    table.declare("speed", 5, ParameterDescriptor("", integer_range=IntegerRange(0, 10, 0)))
    table.declare("label", "a")
    table.declare("serial", 1, ParameterDescriptor("", read_only=True))
    table.declare("counter", 0)
    return table


def _values(client: Any, names: list[str]) -> dict[str, object]:
    return {n: v.value for n, v in client.get(NODE, names).values().items()}


# -- trap 4: validation and atomicity -----------------------------------------------------------


@pytest.mark.parametrize(
    ("params", "code"),
    [
        ({"speed": "fast"}, ErrorCode.TYPE_MISMATCH),
        ({"speed": 2.5}, ErrorCode.TYPE_MISMATCH),  # no double -> integer narrowing
        ({"speed": 11}, ErrorCode.OUT_OF_RANGE),
        ({"serial": 2}, ErrorCode.READ_ONLY),
        ({"nope": 1}, ErrorCode.NOT_FOUND),
    ],
)
def test_each_bad_write_is_refused_by_name_and_the_server_keeps_serving(
    dds: DdsSession, params: dict[str, object], code: ErrorCode
) -> None:
    table = strict_table()
    dds.server(table)
    client = dds.client()
    client.wait_for_node(NODE, timeout=5.0)
    before = table.revision
    reply = client.set(NODE, params)
    (result,) = reply.results
    assert (result.name, result.successful, result.code) == (next(iter(params)), False, code)
    assert result.reason  # says why
    assert reply.revision == before == table.revision
    assert _values(client, ["speed", "serial"]) == {"speed": 5, "serial": 1}
    assert client.set(NODE, {"speed": 6}).successful  # still serving


def test_mixed_set_applies_the_good_ones_and_atomic_set_applies_none(dds: DdsSession) -> None:
    table = strict_table()
    dds.server(table)
    client = dds.client()
    client.wait_for_node(NODE, timeout=5.0)
    before = table.revision

    reply = client.set(NODE, {"speed": 7, "serial": 3, "nope": 1, "label": "b"})
    assert [(r.name, r.successful, r.code) for r in reply.results] == [
        ("speed", True, None),
        ("serial", False, ErrorCode.READ_ONLY),
        ("nope", False, ErrorCode.NOT_FOUND),
        ("label", True, None),
    ]
    assert reply.revision == before + 1  # the good ones in one revision
    assert _values(client, ["speed", "label", "serial"]) == {"speed": 7, "label": "b", "serial": 1}

    atomic = client.set(NODE, {"speed": 8, "label": "c", "serial": 9}, atomic=True)
    assert [(r.name, r.successful) for r in atomic.results] == [
        ("speed", False),
        ("label", False),
        ("serial", False),
    ]
    assert atomic.results[2].code is ErrorCode.READ_ONLY
    assert atomic.revision == before + 1
    got = client.get(NODE, ["speed", "label"])
    assert got.revision == before + 1  # nothing committed
    assert {n: v.value for n, v in got.values().items()} == {"speed": 7, "label": "b"}

    ok = client.set(NODE, {"speed": 9, "label": "d"}, atomic=True)
    assert ok.successful and ok.revision == before + 2


def test_compare_and_set_refuses_a_stale_revision(dds: DdsSession) -> None:
    table = strict_table()
    dds.server(table)
    client = dds.client()
    client.wait_for_node(NODE, timeout=5.0)
    seen = client.get(NODE, ["speed"]).revision
    assert client.set(NODE, {"speed": 1}, if_revision=seen).successful
    stale = client.set(NODE, {"speed": 2}, if_revision=seen)
    assert [(r.successful, r.code) for r in stale.results] == [(False, ErrorCode.CONFLICT)]
    assert table.get("speed").value == 1


def test_compare_and_set_on_a_revision_of_an_earlier_start_is_refused(dds: DdsSession) -> None:
    """A revision repeats across a restart (r9 again), (incarnation, revision) does not:
    a set made against the node before its restart conflicts, and the reply, the presence
    and a monitor all carry the new incarnation."""
    monitor = dds.monitor()
    first = strict_table()
    server = dds.server(first)
    client = dds.client()
    before = client.wait_for_node(NODE, timeout=5.0).at
    assert before.incarnation == server.incarnation(NODE) != 0
    assert client.get(NODE, ["speed"]).at == before
    server.close()
    again = strict_table()  # the same declarations: the same revision as before
    restarted = dds.server(again)
    assert again.revision == before.revision
    assert wait_until(lambda: (client.node_info(NODE) or before).incarnation != before.incarnation, 5.0)
    now = client.node_info(NODE)
    assert now is not None and now.at == (restarted.incarnation(NODE), before.revision)
    stale = client.set(NODE, {"speed": 2}, if_revision=before, atomic=True)
    assert [(r.successful, r.code) for r in stale.results] == [(False, ErrorCode.CONFLICT)]
    assert "incarnation" in stale.results[0].reason and stale.at == now.at  # the node's current state
    assert again.get("speed").value == 5 and again.revision == before.revision  # nothing applied
    assert client.set(NODE, {"speed": 2}, if_revision=before.revision).successful  # revision alone: as before
    ok = client.set(NODE, {"speed": 3}, if_revision=stale.at._replace(revision=before.revision + 1))
    assert ok.successful and ok.at == (now.incarnation, before.revision + 2)
    assert wait_until(lambda: monitor.snapshot()[NODE].incarnation == now.incarnation, 5.0)


def test_concurrent_sets_from_threads_never_corrupt_the_table(dds: DdsSession) -> None:
    table = strict_table()
    dds.server(table)
    clients = [dds.client(timeout=10.0) for _ in range(2)]
    for c in clients:
        c.wait_for_node(NODE, timeout=5.0)
    start = table.revision
    written: dict[int, int] = {}  # revision -> value
    failures: list[Any] = []
    lock = threading.Lock()

    def writer(t: int) -> None:
        client = clients[t % 2]
        for i in range(60):
            value = t * 1000 + i
            # a pair that must stay consistent: counter and label always written together
            reply = client.set(NODE, {"counter": value, "label": f"v{value}"}, atomic=bool(i % 2))
            with lock:
                if reply.successful:
                    written[reply.revision] = value
                else:
                    failures.append(reply.results)

    threads = [threading.Thread(target=writer, args=(t,)) for t in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(30)
    assert failures == []
    assert len(written) == 240  # one distinct revision per committed set
    assert sorted(written) == list(range(start + 1, start + 241))
    final = _values(clients[0], ["counter", "label"])
    last = written[max(written)]
    assert final == {"counter": last, "label": f"v{last}"}
    assert table.revision == start + 240


# -- trap 5: no silent truncation ----------------------------------------------------------------


def test_get_reports_a_status_per_name(dds: DdsSession) -> None:
    dds.server(strict_table())
    client = dds.client()
    client.wait_for_node(NODE, timeout=5.0)
    reply = client.get(NODE, ["speed", "ghost.one", "label", "", "ghost.two"], with_descriptors=True)
    assert [(r.name, r.code) for r in reply.results] == [
        ("speed", None),
        ("ghost.one", ErrorCode.NOT_FOUND),
        ("label", None),
        ("", ErrorCode.INVALID_NAME),
        ("ghost.two", ErrorCode.NOT_FOUND),
    ]
    assert {n: v.value for n, v in reply.values().items()} == {"speed": 5, "label": "a"}
    speed = reply.results[0].descriptor
    assert speed is not None and speed.integer_range == IntegerRange(0, 10, 0)
    assert [m.name for m in reply.missing()] == ["ghost.one", "", "ghost.two"]


def test_a_set_of_1500_parameters_is_one_revision(dds: DdsSession) -> None:
    table = ParameterTable("bulk", allow_undeclared=True)
    table.declare("keep", 1)
    events: list[MonitorEvent] = []
    lock = threading.Lock()

    def record(e: MonitorEvent) -> None:
        with lock:
            events.append(e)

    monitor = dds.monitor(on_event=record)
    dds.server(table)
    client = dds.client(timeout=10.0)
    client.wait_for_node("bulk", timeout=5.0)
    assert monitor.wait_complete(["bulk"], timeout=5.0)
    before = table.revision

    params = {f"bulk.p{i:04}": i * 2 for i in range(1500)}  # the seed capped a request at 64
    reply = client.set("bulk", params)
    assert len(reply.results) == 1500 and reply.successful
    assert reply.revision == before + 1 == table.revision

    got = client.get("bulk", list(params))
    assert len(got.results) == 1500
    assert {n: v.value for n, v in got.values().items()} == params

    assert monitor.wait_until(lambda s: len(s["bulk"].parameters) == 1501, timeout=5.0)
    with lock:
        added = [e for e in events if e.event is EventKind.ADDED and e.name.startswith("bulk.")]
    assert len(added) == 1500
    assert {e.revision for e in added} == {before + 1}  # a watcher can group the change


def test_over_limit_requests_fail_client_side_with_our_errors(dds: DdsSession) -> None:
    table = strict_table()
    dds.server(table)
    client = dds.client()
    client.wait_for_node(NODE, timeout=5.0)
    before = table.revision
    one = ParameterValue.from_python(1)
    too_many = [Parameter(f"p{i}", one) for i in range(MAX_PARAMETERS_PER_REQUEST + 1)]
    with pytest.raises(TooLargeError, match=str(MAX_PARAMETERS_PER_REQUEST)):
        client.set(NODE, too_many)
    with pytest.raises(TooLargeError):
        client.get(NODE, [f"p{i}" for i in range(MAX_PARAMETERS_PER_REQUEST + 1)])
    with pytest.raises(TooLargeError, match="label"):
        client.set(NODE, {"label": "x" * (MAX_VALUE_BYTES + 1)})
    with pytest.raises(InvalidNameError, match="255"):
        client.get("n" * 256, ["speed"])
    with pytest.raises(InvalidNameError):
        client.set(NODE, {"bad name": 1})
    assert table.revision == before
    assert client.get_value(NODE, "speed").value == 5  # and the client still works


# -- bad requests from a raw Cyclone writer ------------------------------------------------------


def _pv(**kwargs: Any) -> Any:
    return wire.ParameterValue(**kwargs)


def test_raw_garbage_requests_get_errors_and_the_server_keeps_serving(dds: DdsSession) -> None:
    table = strict_table()
    dds.server(table)
    client = dds.client()
    client.wait_for_node(NODE, timeout=5.0)
    before = table.revision

    dp = dds.participant()
    qos = QosProfiles.load()
    writers = {
        name: DataWriter(dp, make_topic(dp, name, wire.TOPICS[name]), qos.writer(name))
        for name in ("SetParametersRequest", "GetParametersRequest", "ListParametersRequest")
    }
    readers = {
        name: DataReader(dp, make_topic(dp, name, wire.TOPICS[name]), qos.reader(name))
        for name in ("SetParametersResponse", "GetParametersResponse", "ListParametersResponse")
    }
    me = 0xBAD

    def ask(topic: str, sample: Any) -> Any:
        writers[topic].write(sample)
        reply_topic = topic.replace("Request", "Response")
        got: list[Any] = []

        def arrived() -> bool:
            got.extend(
                s
                for s in readers[reply_topic].take(N=10)
                if s.sample_info.valid_data and s.client_id == me and s.request_id == sample.request_id
            )
            return bool(got)

        assert wait_until(arrived, timeout=5.0), f"no reply to {sample}"
        return got[0]

    # unknown type byte, an empty name, a bad name, a good one: per-name results
    reply = ask(
        "SetParametersRequest",
        wire.SetParametersRequest(
            node_id=NODE,
            client_id=me,
            request_id=1,
            parameters=[
                wire.Parameter("speed", _pv(type=42, integer_value=3)),
                wire.Parameter("", _pv(type=2, integer_value=3)),
                wire.Parameter("a b!", _pv(type=2, integer_value=3)),
                wire.Parameter("label", _pv(type=4, string_value="raw")),
            ],
        ),
    )
    assert [(r.name, r.successful, r.code) for r in reply.results] == [
        ("speed", False, "INVALID_VALUE"),
        ("", False, "INVALID_NAME"),
        ("a b!", False, "INVALID_NAME"),
        ("label", True, ""),
    ]
    assert table.get("label").value == "raw" and table.get("speed").value == 5

    # the same garbage atomically: nothing changes
    reply = ask(
        "SetParametersRequest",
        wire.SetParametersRequest(
            node_id=NODE,
            client_id=me,
            request_id=2,
            atomic=True,
            parameters=[
                wire.Parameter("label", _pv(type=4, string_value="never")),
                wire.Parameter("speed", _pv(type=255)),
            ],
        ),
    )
    assert [r.successful for r in reply.results] == [False, False]
    assert table.get("label").value == "raw" and table.revision == before + 1

    # an empty set, a type byte that disagrees with the member set, a leading "/" node id
    reply = ask(
        "SetParametersRequest", wire.SetParametersRequest(node_id="/" + NODE, client_id=me, request_id=3)
    )
    assert reply.results == [] and reply.code == ""
    reply = ask(
        "SetParametersRequest",
        wire.SetParametersRequest(
            node_id=NODE,
            client_id=me,
            request_id=4,
            parameters=[wire.Parameter("speed", _pv(type=4, integer_value=3, string_value="3"))],
        ),
    )
    assert [(r.successful, r.code) for r in reply.results] == [(False, "TYPE_MISMATCH")]

    # get with garbage names; list with a silly depth and prefixes
    reply = ask(
        "GetParametersRequest",
        wire.GetParametersRequest(
            node_id=NODE, client_id=me, request_id=5, names=["", "..", "speed", "x" * 300]
        ),
    )
    assert [(r.name[:5], r.code) for r in reply.results] == [
        ("", "INVALID_NAME"),
        ("..", "INVALID_NAME"),
        ("speed", ""),
        ("xxxxx", "INVALID_NAME"),
    ]
    reply = ask(
        "ListParametersRequest",
        wire.ListParametersRequest(
            node_id=NODE, client_id=me, request_id=6, depth=2**64 - 1, prefixes=["", "..."]
        ),
    )
    assert reply.code in ("", "INVALID_VALUE", "INVALID_NAME")

    # a request for a node nobody hosts is not answered, and does no harm
    writers["GetParametersRequest"].write(
        wire.GetParametersRequest(node_id="nobody", client_id=me, request_id=7, names=["speed"])
    )

    # the server still answers normal requests
    assert client.get_value(NODE, "speed").value == 5
    assert client.set(NODE, {"speed": 4}).successful
    assert client.list(NODE).names == ("counter", "label", "serial", "speed")
