"""The DDS side of the baselines, and counting with the builtin topics.

* :class:`Echo` and :class:`EchoClient` / :func:`serve_echo`: the floor. A raw
  request/reply on a keyed topic (key ``node_id``, like ours), with the serialized
  sizes of a real get, the same QoS profiles and the same wake-up mechanism as
  :class:`~paramdds.dds.client.ParameterClient` (a WaitSet dispatcher thread
  completing a ``concurrent.futures.Future``). Samples are pre-encoded bytes
  written and taken raw (``write_serialized`` / ``take_serialized``); only the ids
  are patched in and read out at fixed offsets. No codec runs at all, so nothing
  paramdds does (encoding, decoding, the table, the filters) is in the floor.
* :class:`PollingClient`: a polling client (the design paramdds replaced), a get request answered by the
  paramdds server, whose reply is found by taking from the reader and sleeping
  10 ms between attempts.
* :class:`IndexedWaitSet`: a WaitSet that reports *which* attached entities
  triggered (Cyclone's attach argument), so the ROS 2 layout baseline with
  thousands of readers dispatches in O(triggered), not O(readers). Without it
  the baseline would pay for our Python loop rather than for its topic layout.
* :func:`census` / :func:`own_endpoints`: topics and endpoints counted from
  ``DCPSTopic`` / ``DCPSPublication`` / ``DCPSSubscription``.
"""

import itertools
import secrets
import struct
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import key
from cyclonedds.idl.types import sequence, uint8, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from ..dds._binding import cookie_buffer, waitset_attach_indexed, waitset_wait_indexed, write_serialized
from ..dds.dispatch import Dispatcher
from ..dds.qos import QosProfiles
from ..dds.topics import make_topic
from ..dds.wire import types as wire

ECHO_REQUEST = "BenchEchoRequest"  # names chosen so the Request / Reply QoS profiles apply
ECHO_REPLY = "BenchEchoResponse"
ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any


@dataclass
class Echo(IdlStruct, typename="paramdds_bench.Echo"):
    client_id: uint64 = 0
    request_id: uint64 = 0
    node_id: str = ""
    key("node_id")
    payload: sequence[uint8] = field(default_factory=list)


_IDS = struct.Struct("<QQ")


def _ids_offset() -> int:
    """Where (client_id, request_id) sit in a serialized Echo (found, not assumed)."""
    marker = Echo(client_id=0x0102030405060708, request_id=0x1112131415161718).serialize()
    offset = marker.find(_IDS.pack(0x0102030405060708, 0x1112131415161718))
    if offset < 0:
        raise RuntimeError("the Echo encoding changed: ids not found little-endian")
    return offset


def get_sizes(node: str, name: str, value: object) -> tuple[int, int]:
    """Serialized sizes (request, reply) of a one-name get, as the client and server send them."""
    from ..core.values import ParameterValue
    from ..dds.wire.convert import value_to_wire

    req = wire.GetParametersRequest(node_id=node, client_id=2**63, request_id=1, names=[name])
    rep = wire.GetParametersResponse(
        node_id=node,
        client_id=2**63,
        request_id=1,
        revision=1,
        results=[wire.GetParameterResult(name=name, value=value_to_wire(ParameterValue.from_python(value)))],
    )
    return len(req.serialize()), len(rep.serialize())


def echo_template(size: int, node: str = "bench_n0000") -> bytearray:
    """A serialized Echo of ``size`` bytes (or the smallest above it), for patching ids into."""
    base = len(Echo(node_id=node).serialize())
    return bytearray(Echo(node_id=node, payload=[7] * max(0, size - base)).serialize())


def serve_echo(participant: Any, qos: QosProfiles, reply_size: int) -> Dispatcher:
    """Answer every Echo request with a pre-encoded Echo of ``reply_size`` bytes (same ids)."""
    writer = DataWriter(participant, make_topic(participant, ECHO_REPLY, Echo), qos.writer(ECHO_REPLY))
    reply = echo_template(reply_size)
    at = _ids_offset()
    reader = DataReader(participant, make_topic(participant, ECHO_REQUEST, Echo), qos.reader(ECHO_REQUEST))
    dispatcher = Dispatcher(participant, "bench-echo")

    def on_requests(samples: Sequence[tuple[bytes, Any]]) -> None:
        for data, info in samples:
            if info.valid_data:
                reply[at : at + 16] = data[at : at + 16]
                write_serialized(writer, bytes(reply))

    dispatcher.add_raw(reader, lambda data, _info: data, on_requests)
    dispatcher.start()
    dispatcher._bench_keep = (writer, reader)  # type: ignore[attr-defined]
    return dispatcher


class EchoClient:
    """Raw request/reply with the client's wake-up mechanism: dispatcher thread + Future."""

    def __init__(self, participant: Any, qos: QosProfiles, request_size: int) -> None:
        self._writer = DataWriter(
            participant, make_topic(participant, ECHO_REQUEST, Echo), qos.writer(ECHO_REQUEST)
        )
        reader = DataReader(participant, make_topic(participant, ECHO_REPLY, Echo), qos.reader(ECHO_REPLY))
        self._request = echo_template(request_size)
        self._at = _ids_offset()
        self._ids = itertools.count(1)
        self._pending: dict[int, Future[Any]] = {}
        self.client_id = secrets.randbits(63) or 1  # every echo client sees every reply
        self._dispatcher = Dispatcher(participant, "bench-echo-client")
        self._dispatcher.add_raw(reader, lambda data, _info: data, self._on_replies)
        self._dispatcher.start()
        self._reader = reader

    def _on_replies(self, samples: Sequence[tuple[bytes, Any]]) -> None:
        at = self._at
        for data, info in samples:
            if not info.valid_data:
                continue
            client_id, request_id = _IDS.unpack_from(data, at)
            if client_id == self.client_id:
                future = self._pending.pop(request_id, None)
                if future is not None:
                    future.set_result(request_id)

    def send(self) -> Future[Any]:
        rid = next(self._ids)
        future: Future[Any] = Future()
        self._pending[rid] = future
        _IDS.pack_into(self._request, self._at, self.client_id, rid)
        write_serialized(self._writer, bytes(self._request))
        return future

    def call(self, timeout: float = 5.0) -> Any:
        return self.send().result(timeout)

    def wait_matched(self, timeout: float = 10.0) -> bool:
        return wait_matched([self._writer], [self._reader], timeout)

    def close(self) -> None:
        self._dispatcher.close()


class PollingClient:
    """A polling client: write a get, then take-and-sleep(10 ms) until the reply is there."""

    def __init__(self, participant: Any, qos: QosProfiles, period: float = 0.010) -> None:
        name = "GetParametersRequest"
        self._writer = DataWriter(
            participant, make_topic(participant, name, wire.TOPICS[name]), qos.writer(name)
        )
        name = "GetParametersResponse"
        self._reader = DataReader(
            participant, make_topic(participant, name, wire.TOPICS[name]), qos.reader(name)
        )
        self._ids = itertools.count(1)
        self.client_id = 0x5EED
        self.period = period

    def get(self, node: str, names: list[str], timeout: float = 5.0) -> Any:
        rid = next(self._ids)
        self._writer.write(
            wire.GetParametersRequest(node_id=node, client_id=self.client_id, request_id=rid, names=names)
        )
        deadline = time.monotonic() + timeout
        while True:
            s: Any
            for s in self._reader.take(N=64):
                if s.sample_info.valid_data and s.client_id == self.client_id and s.request_id == rid:
                    return s
            if time.monotonic() > deadline:
                raise TimeoutError(f"no reply to polling get {rid}")
            time.sleep(self.period)


# -- matching, waiting by index ---------------------------------------------------------------


def wait_matched(writers: Sequence[Any], readers: Sequence[Any], timeout: float) -> bool:
    """Poll (1 ms) until every writer and reader has a match; used only outside timed sections."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if all(w.get_publication_matched_status().current_count > 0 for w in writers) and all(
            r.get_subscription_matched_status().current_count > 0 for r in readers
        ):
            return True
        time.sleep(0.001)
    return False


class IndexedWaitSet:
    """A WaitSet whose ``wait`` returns the indices of the entities that triggered."""

    def __init__(self, participant: Any, capacity: int = 1024) -> None:
        self.ws = WaitSet(participant)
        self._buf = cookie_buffer(capacity)

    def attach(self, entity: Any, index: int) -> None:
        waitset_attach_indexed(self.ws, entity, index + 1)  # 0 would read back as None

    def detach(self, entity: Any) -> None:
        self.ws.detach(entity)

    def wait(self, timeout_ns: int) -> list[int]:
        return [cookie - 1 for cookie in waitset_wait_indexed(self.ws, self._buf, timeout_ns)]


# -- the ROS 2 layout: per node six services (twelve topics) + one shared events topic -----------

SERVICES = (
    "get_parameters",
    "get_parameter_types",
    "set_parameters",
    "set_parameters_atomically",
    "describe_parameters",
    "list_parameters",
)
EVENTS_TOPIC = "rt/parameter_events"
_SERVICE_TYPES = {
    "get_parameters": ("GetParametersRequest", "GetParametersResponse"),
    "get_parameter_types": ("GetParametersRequest", "GetParametersResponse"),
    "describe_parameters": ("GetParametersRequest", "GetParametersResponse"),
    "set_parameters": ("SetParametersRequest", "SetParametersResponse"),
    "set_parameters_atomically": ("SetParametersRequest", "SetParametersResponse"),
    "list_parameters": ("ListParametersRequest", "ListParametersResponse"),
}


def request_topic(node: str, service: str) -> str:
    return f"rq/{node}/{service}Request"


def reply_topic(node: str, service: str) -> str:
    return f"rr/{node}/{service}Reply"


class RosLayoutServer:
    """Hosts tables as ROS 2 does: per node six request readers, six reply writers, one events writer.

    The payloads reuse paramdds's wire types and the requests are answered by the
    same core :class:`~paramdds.core.table.ParameterTable`: only the layout differs.
    """

    def __init__(self, participant: Any, qos: QosProfiles) -> None:
        self._dp = participant
        self._qos = qos
        self._ws = IndexedWaitSet(participant, capacity=4096)
        self._slots: list[tuple[Any, Callable[[Any], Any], Any]] = []
        self._entities: list[Any] = []
        self._stopping = False
        self._guard_index = -1
        from cyclonedds.core import GuardCondition

        self._guard = GuardCondition(participant)
        self._ws.attach(self._guard, 10**9)
        self._thread = threading.Thread(target=self._run, name="bench-ros-server", daemon=True)

    def add_node(self, table: Any) -> None:
        node = table.node_id
        dp, qos = self._dp, self._qos
        events = DataWriter(
            dp, make_topic(dp, EVENTS_TOPIC, wire.ParameterEvent), qos.writer("SetParametersResponse")
        )
        self._entities.append(events)
        for service in SERVICES:
            req_type, rep_type = _SERVICE_TYPES[service]
            rq = request_topic(node, service)
            reader = DataReader(dp, make_topic(dp, rq, wire.TOPICS[req_type]), qos.reader(req_type))
            writer = DataWriter(
                dp, make_topic(dp, reply_topic(node, service), wire.TOPICS[rep_type]), qos.writer(rep_type)
            )
            condition = ReadCondition(reader, ANY_STATE)
            self._entities += [reader, writer, condition]
            self._ws.attach(condition, len(self._slots))
            self._slots.append((reader, _handler(service, table), writer))

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._stopping = True
        self._guard.set(True)
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        forever = 2**63 - 1
        while not self._stopping:
            for index in self._ws.wait(forever):
                if index >= len(self._slots):
                    continue
                reader, handler, writer = self._slots[index]
                for s in reader.take(N=64):
                    if s.sample_info.valid_data:
                        writer.write(handler(s))


def _handler(service: str, table: Any) -> Callable[[Any], Any]:
    from ..core.values import Parameter
    from ..dds.wire.convert import descriptor_to_wire, parameter_from_wire, value_to_wire

    def ids(cls: Any, request: Any) -> Any:
        return cls(node_id=table.node_id, client_id=request.client_id, request_id=request.request_id)

    def get(request: Any) -> Any:
        # as rcl_interfaces: get_parameters returns values only, describe_parameters descriptors only
        reply = ids(wire.GetParametersResponse, request)
        describe = service == "describe_parameters"
        reply.revision = table.revision
        reply.results = [
            wire.GetParameterResult(
                name=r.name,
                code=r.code.value if r.code else "",
                value=wire.ParameterValue() if describe or r.value is None else value_to_wire(r.value),
                descriptor=[descriptor_to_wire(r.descriptor)] if r.descriptor is not None else [],
            )
            for r in table.get_many(list(request.names), with_descriptors=describe)
        ]
        return reply

    def list_(request: Any) -> Any:
        reply = ids(wire.ListParametersResponse, request)
        result = table.list(list(request.prefixes), int(request.depth))
        reply.revision, reply.names, reply.prefixes = (
            table.revision,
            list(result.names),
            list(result.prefixes),
        )
        return reply

    def set_(request: Any) -> Any:
        reply = ids(wire.SetParametersResponse, request)
        params: list[Parameter] = [parameter_from_wire(p) for p in request.parameters]
        outcome = (table.set_atomically if service == "set_parameters_atomically" else table.set)(params)
        reply.revision = outcome.revision
        reply.results = [
            wire.SetParameterResult(name=r.name, successful=r.successful, reason=r.reason)
            for r in outcome.results
        ]
        return reply

    if service.startswith("set"):
        return set_
    return list_ if service == "list_parameters" else get


# -- counting ---------------------------------------------------------------------------------


_MAX_ROWS = 200_000


def _builtin_reader(participant: Any, which: str) -> Any:
    from cyclonedds import builtin

    topic = {
        "topic": builtin.BuiltinTopicDcpsTopic,
        "publication": builtin.BuiltinTopicDcpsPublication,
        "subscription": builtin.BuiltinTopicDcpsSubscription,
    }[which]
    return builtin.BuiltinDataReader(participant, topic)


def _rows(reader: Any) -> list[Any]:
    return [s for s in reader.read(N=_MAX_ROWS) if s.sample_info.valid_data]


def _user(name: str) -> bool:
    return not name.startswith("DCPS")


def own_endpoints(participant: Any) -> int:
    """Writers + readers of user topics that belong to ``participant`` (builtin topics)."""
    me = participant.guid
    count = 0
    for which in ("publication", "subscription"):
        reader = _builtin_reader(participant, which)
        count += sum(1 for s in _rows(reader) if s.participant_key == me and _user(s.topic_name))
    return count


def census(participant: Any, *, settle: float = 0.3, timeout: float = 20.0) -> dict[str, int]:
    """Distinct user topics (``DCPSTopic``; needs topic discovery everywhere) and all endpoints.

    Counts are read until they stop changing for ``settle`` seconds.
    """
    deadline = time.monotonic() + timeout
    topic_reader = _builtin_reader(participant, "topic")
    endpoint_readers = [_builtin_reader(participant, w) for w in ("publication", "subscription")]
    last: tuple[int, int] | None = None
    stable_since = time.monotonic()
    while True:
        topics = {s.topic_name for s in _rows(topic_reader) if _user(s.topic_name)}
        endpoints = sum(
            1
            for reader in endpoint_readers
            for s in _rows(reader)
            if _user(s.topic_name) and s.participant_key != participant.guid
        )
        now = (len(topics), endpoints)
        if now != last:
            last, stable_since = now, time.monotonic()
        elif time.monotonic() - stable_since >= settle or time.monotonic() > deadline:
            return {"topics": now[0], "endpoints": now[1]}
        time.sleep(0.05)


class RosLayoutMonitor:
    """What ``ros2 param dump`` over every node does: per node, clients for list, get and
    describe (a request writer and a reply reader each), wait until those match the node's
    services, then list → get + describe. Every node is worked on concurrently (one
    WaitSet, requests pipelined), which is the most favourable form of the baseline.

    As rclcpp does, each request is sent once, when the node's services are ready
    (request writer and reply reader matched). rclcpp never resends: a reply sent
    before the server's reply writer matched our reader is lost and the call hangs.
    So that the bench completes, such a request is sent again after ``retry``
    seconds; :attr:`resends` counts them (the price of the race, reported).
    """

    CALLS = ("list_parameters", "get_parameters", "describe_parameters")

    def __init__(self, participant: Any, qos: QosProfiles, nodes: Sequence[str], retry: float = 2.0) -> None:
        from cyclonedds.core import DDSStatus

        self._retry = retry
        self.resends = 0
        self.nodes = list(nodes)
        n = len(self.nodes)
        self._ws = IndexedWaitSet(participant, capacity=max(1024, 8 * n))
        # index = node * 8 + slot: slots 0-2 writers, 3-5 readers (matching), 6 the read condition
        self._writers: list[dict[str, Any]] = []
        self._readers: list[dict[str, Any]] = []
        self._conditions: list[list[tuple[str, Any, Any]]] = []
        dp = participant
        for node in self.nodes:
            writers, readers, conds = {}, {}, []
            for call in self.CALLS:
                req_type, rep_type = _SERVICE_TYPES[call]
                w = DataWriter(
                    dp, make_topic(dp, request_topic(node, call), wire.TOPICS[req_type]), qos.writer(req_type)
                )
                r = DataReader(
                    dp, make_topic(dp, reply_topic(node, call), wire.TOPICS[rep_type]), qos.reader(rep_type)
                )
                w.set_status_mask(DDSStatus.PublicationMatched)
                r.set_status_mask(DDSStatus.SubscriptionMatched)
                writers[call], readers[call] = w, r
                conds.append((call, r, ReadCondition(r, ANY_STATE)))
            self._writers.append(writers)
            self._readers.append(readers)
            self._conditions.append(conds)
        for i in range(n):
            for j, call in enumerate(self.CALLS):
                self._ws.attach(self._writers[i][call], i * 8 + j)
                self._ws.attach(self._readers[i][call], i * 8 + 3 + j)
                self._ws.attach(self._conditions[i][j][2], i * 8 + 6)
        self._status = DDSStatus

    def run(self, timeout: float) -> dict[str, dict[str, tuple[Any, Any]]]:
        """Full state: node → name → (value, descriptor). TimeoutError when not all arrive."""
        n = len(self.nodes)
        unmatched = [6] * n
        matched = [[False] * 6 for _ in range(n)]
        names: list[list[str] | None] = [None] * n
        values: list[dict[str, Any] | None] = [None] * n
        descriptors: list[dict[str, Any] | None] = [None] * n
        outstanding: list[dict[str, tuple[int, float]]] = [{} for _ in range(n)]  # call -> (request id, sent)
        ids = itertools.count(1)
        done = 0
        client_id = 0xB45E

        def send(i: int, call: str) -> None:
            rid = next(ids)
            node = self.nodes[i]
            if call == "list_parameters":
                sample: Any = wire.ListParametersRequest(node_id=node, client_id=client_id, request_id=rid)
            else:
                sample = wire.GetParametersRequest(
                    node_id=node, client_id=client_id, request_id=rid, names=list(names[i] or [])
                )
            outstanding[i][call] = (rid, time.monotonic())
            self._writers[i][call].write(sample)

        def check_match(i: int, j: int) -> None:
            if matched[i][j]:
                return
            call = self.CALLS[j % 3]
            if j < 3:
                w = self._writers[i][call]
                w.take_status(self._status.PublicationMatched)
                ok = w.get_publication_matched_status().current_count > 0
            else:
                r = self._readers[i][call]
                r.take_status(self._status.SubscriptionMatched)
                ok = r.get_subscription_matched_status().current_count > 0
            if ok:
                matched[i][j] = True
                unmatched[i] -= 1
                if unmatched[i] == 0:
                    send(i, "list_parameters")

        for i in range(n):
            for j in range(6):
                check_match(i, j)
        deadline = time.monotonic() + timeout
        while done < n:
            now = time.monotonic()
            if now > deadline:
                raise TimeoutError(
                    f"baseline monitor: {n - done} of {n} nodes incomplete after {timeout:g} s"
                )
            for index in self._ws.wait(int(self._retry * 1e9 / 10)):
                i, slot = divmod(index, 8)
                if slot < 6:
                    check_match(i, slot)
                    continue
                for call, reader, _ in self._conditions[i]:
                    for s in reader.take(N=16):
                        if not s.sample_info.valid_data:
                            continue
                        pending = outstanding[i].get(call)
                        if pending is None or pending[0] != s.request_id:
                            continue
                        del outstanding[i][call]
                        if call == "list_parameters":
                            names[i] = list(s.names)
                            send(i, "get_parameters")
                            send(i, "describe_parameters")
                        elif call == "get_parameters":
                            values[i] = {r.name: r.value for r in s.results}
                        else:
                            descriptors[i] = {r.name: r.descriptor for r in s.results}
                        if call != "list_parameters" and values[i] is not None and descriptors[i] is not None:
                            done += 1
            now = time.monotonic()
            for i in range(n):
                for call, (_rid, sent) in list(outstanding[i].items()):
                    if now - sent > self._retry:
                        self.resends += 1
                        send(i, call)
        return {
            node: {k: (values[i][k], (descriptors[i] or {}).get(k)) for k in (values[i] or {})}  # type: ignore[index]
            for i, node in enumerate(self.nodes)
        }
