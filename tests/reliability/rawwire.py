"""A foreign peer on our topics: plain cyclonedds writers and readers, no paramdds client.

Everything a :class:`RawPeer` sends bypasses the client's checks (names, sizes,
types), so the server meets exactly the samples a buggy or hostile program could
write. Replies are collected by (client_id, request_id).
"""

from __future__ import annotations

import time
from typing import Any

from cyclonedds.core import Policy
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Qos
from cyclonedds.sub import DataReader
from cyclonedds.util import duration

from paramdds.dds._binding import write_serialized
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire

REQUESTS = ("SetParametersRequest", "GetParametersRequest", "ListParametersRequest")
REPLIES = ("SetParametersResponse", "GetParametersResponse", "ListParametersResponse")

# every published state sample, none coalesced (the state profile keeps one per instance)
EVERY_EVENT = Qos(
    Policy.Reliability.Reliable(duration(seconds=1)),
    Policy.Durability.Volatile,
    Policy.History.KeepAll,
)


class RawPeer:
    def __init__(self, participant: Any, *, count_events: bool = False) -> None:
        qos = QosProfiles.load()
        self.writers = {
            name: DataWriter(participant, make_topic(participant, name, wire.TOPICS[name]), qos.writer(name))
            for name in REQUESTS
        }
        self.readers = {
            name: DataReader(participant, make_topic(participant, name, wire.TOPICS[name]), qos.reader(name))
            for name in REPLIES
        }
        self.events = (
            DataReader(
                participant, make_topic(participant, "ParameterEvents", wire.ParameterEvent), EVERY_EVENT
            )
            if count_events
            else None
        )
        self._replies: dict[tuple[str, str, int, int], list[Any]] = {}
        self.event_log: list[Any] = []

    def send(self, sample: Any) -> None:
        name = type(sample).__name__
        self.writers[name].write(sample)

    def send_bytes(self, topic: str, data: bytes) -> None:
        """Write ``data`` as a serialized sample, bypassing every encoder (cyclonedds C API)."""
        padded = data.ljust((len(data) + 3) & ~3, b"\0")
        write_serialized(self.writers[topic], padded)

    def _pump(self) -> None:
        for name, reader in self.readers.items():
            for s in reader.take(N=1024):
                if s.sample_info.valid_data:
                    self._replies.setdefault((name, s.node_id, s.client_id, s.request_id), []).append(s)
        if self.events is not None:
            self.event_log.extend(s for s in self.events.take(N=4096) if s.sample_info.valid_data)

    def replies(self, request: Any, count: int = 1, timeout: float = 3.0) -> list[Any]:
        """The replies to ``request`` (waits until ``count`` arrived or ``timeout`` passed)."""
        key = (
            type(request).__name__.replace("Request", "Response"),
            request.node_id.removeprefix("/"),  # replies carry the canonical node id
            request.client_id,
            request.request_id,
        )
        deadline = time.monotonic() + timeout
        while True:
            self._pump()
            got = self._replies.get(key, [])
            if len(got) >= count or time.monotonic() >= deadline:
                return list(got)
            time.sleep(0.002)

    def call(self, request: Any, timeout: float = 3.0) -> Any:
        self.send(request)
        got = self.replies(request, 1, timeout)
        assert got, f"no reply to {type(request).__name__} {request.request_id} within {timeout} s"
        return got[0]

    def first_answer(self, request: Any, tries: int = 40) -> Any:
        """Send ``request`` until it is answered (a copy written before this peer matched the
        node is lost: VOLATILE)."""
        for _ in range(tries):
            self.send(request)
            got = self.replies(request, 1, timeout=0.5)
            if got:
                return got[0]
        raise AssertionError(f"no reply to {type(request).__name__} {request.request_id} after {tries} sends")

    def pump_events(self) -> list[Any]:
        self._pump()
        return self.event_log


def same_reply(a: Any, b: Any) -> bool:
    """Replies equal in every member that carries meaning."""
    fields = ("node_id", "client_id", "request_id", "revision", "code", "reason")
    return all(getattr(a, f) == getattr(b, f) for f in fields) and [
        (r.name, r.successful, r.reason, r.code) for r in a.results
    ] == [(r.name, r.successful, r.reason, r.code) for r in b.results]
