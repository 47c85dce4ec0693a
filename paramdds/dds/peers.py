"""Peers whose type or QoS does not match ours: reported loudly, once per peer endpoint.

A DDS peer that uses one of our topic names with another type (an old release,
an edited IDL, an ``@appendable`` copy) or an incompatible QoS (a best-effort
state writer, a volatile writer for a transient-local reader) is simply never
matched: without this module its requests would time out and its state would
never show, with nothing said anywhere.

Cyclone reports each such peer on our side as a status: REQUESTED_INCOMPATIBLE_QOS
on our reader, OFFERED_INCOMPATIBLE_QOS on our writer (a type mismatch is the
policy TYPE_CONSISTENCY_ENFORCEMENT, an unreadable encoding DATA_REPRESENTATION),
INCONSISTENT_TOPIC on the topic. The status says which policy, not which peer,
and the endpoint it names is often not a Python object yet (a match found while
its constructor runs). So an event only wakes :class:`PeerWatch`'s thread, which
then checks every reader and writer of the participant for these statuses and
reads Cyclone's builtin discovery topics: the endpoints on that topic name that
are not matched with ours are the culprits, and the participant they belong to
gives the host, pid and process name. Each is logged
once, as a warning on the ``paramdds.peers`` logger, and kept in
:meth:`PeerWatch.mismatches`.

Costs nothing while every peer matches: the listener's callbacks (which run on
Cyclone's own threads, so they only queue the event) are the only thing
installed; the reporting thread and the builtin readers are created on the
first mismatch. :func:`.participant.close_participant` removes the listener
before deleting the participant, as a listener still attached at exit can hang
it; for a process that never calls it, an ``atexit`` hook does.
"""

from __future__ import annotations

import atexit
import logging
import queue
import threading
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cyclonedds.sub import DataReader

from ._binding import live_endpoints

__all__ = ["POLICY_NAMES", "PeerMismatch", "PeerWatch"]

log = logging.getLogger("paramdds.peers")

# dds_qos_policy_id_t, as Cyclone numbers the policies in these statuses
POLICY_NAMES = {
    1: "USER_DATA",
    2: "DURABILITY",
    3: "PRESENTATION",
    4: "DEADLINE",
    5: "LATENCY_BUDGET",
    6: "OWNERSHIP",
    7: "OWNERSHIP_STRENGTH",
    8: "LIVELINESS",
    9: "TIME_BASED_FILTER",
    10: "PARTITION",
    11: "RELIABILITY",
    12: "DESTINATION_ORDER",
    13: "HISTORY",
    14: "RESOURCE_LIMITS",
    15: "ENTITY_FACTORY",
    16: "WRITER_DATA_LIFECYCLE",
    17: "READER_DATA_LIFECYCLE",
    18: "TOPIC_DATA",
    19: "GROUP_DATA",
    20: "TRANSPORT_PRIORITY",
    21: "LIFESPAN",
    22: "DURABILITY_SERVICE",
    23: "PROPERTY",
    24: "TYPE_CONSISTENCY_ENFORCEMENT (a different type)",
    25: "DATA_REPRESENTATION",
}

_IDLE = 5.0  # seconds without an event before the thread ends (the next event starts another)
_SETTLE = 0.05  # seconds between an event and the scan


@dataclass(frozen=True)
class PeerMismatch:
    """One peer endpoint that Cyclone would not match with ours."""

    topic: str
    peer_kind: str  # "writer" or "reader": the peer's endpoint
    policy: str  # the policy Cyclone last named for our endpoint when this peer was found ("RELIABILITY")
    type_name: str  # the peer's type name (ours: paramdds::<Type>)
    endpoint: str  # the peer endpoint's GUID
    host: str
    pid: str
    process: str

    def message(self) -> str:
        return (
            f"a DDS peer does not match and is ignored: {self.peer_kind} on topic {self.topic!r} "
            f"(type {self.type_name}) of process {self.process!r} pid {self.pid} on host {self.host!r}, "
            f"endpoint {self.endpoint}: incompatible {self.policy}"
        )


def _by_design(ours: Any, endpoint: Any) -> bool:
    """A volatile request writer and a transient-local assignment reader, which do not match.

    By design: a server reads SetParametersRequest twice, interactive requests
    (volatile) and retained assignments (transient-local). A client's volatile
    writer matches the first, and the second correctly ignores it; each side
    sees the other as incompatible in DURABILITY.
    """
    from cyclonedds.qos import Policy

    def durability(qos: Any) -> Any:  # the binding's Qos has no get()
        if Policy.Durability in qos:
            return qos[Policy.Durability]
        return Policy.Durability.Volatile

    mine, theirs = durability(ours.get_qos()), durability(endpoint.qos)
    return bool(
        ours.topic.name == "SetParametersRequest"
        and {mine, theirs} == {Policy.Durability.Volatile, Policy.Durability.TransientLocal}
    )


def _closer(ref: weakref.ref[PeerWatch]) -> Callable[[], None]:
    def close() -> None:
        watch = ref()
        if watch is not None:
            watch.close()

    return close


class PeerWatch:
    """Reports mismatched peers of one participant (see the module doc)."""

    def __init__(self, participant: Any) -> None:
        from cyclonedds.core import Listener

        self._dp = participant
        self._own = participant.guid
        self._events: queue.SimpleQueue[bool] = queue.SimpleQueue()  # True: scan, False: stop
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._builtin: dict[str, Any] = {}
        self._seen: set[str] = set()
        self._found: list[PeerMismatch] = []
        self._closed = False
        # The entity Cyclone names is often not a Python object yet (a match found while
        # its constructor runs), so an event only wakes the thread, which then checks
        # every endpoint of the participant.
        listener = Listener(  # type: ignore[no-untyped-call]
            on_requested_incompatible_qos=lambda _reader, _status: self._wake(),
            on_offered_incompatible_qos=lambda _writer, _status: self._wake(),
            on_inconsistent_topic=lambda _topic, _status: self._wake(),
        )
        participant.set_listener(listener)
        self._at_exit = _closer(weakref.ref(self))
        atexit.register(self._at_exit)

    def mismatches(self) -> list[PeerMismatch]:
        """Every mismatched peer endpoint reported so far."""
        with self._lock:
            return list(self._found)

    def close(self) -> None:
        """Remove the listener and stop the thread (before the participant is deleted)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            thread = self._thread
        atexit.unregister(self._at_exit)
        try:
            self._dp.set_listener(None)
        except Exception:  # the participant is already deleted, and its listener with it
            log.debug("participant gone before its peer watch", exc_info=True)
        self._events.put(False)
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=2.0)

    # ---- on Cyclone's thread: queue and return ------------------------------------------------

    def _wake(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._events.put(True)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="paramdds-peers", daemon=True)
                self._thread.start()

    # ---- the reporting thread -----------------------------------------------------------------

    def _run(self) -> None:
        while True:
            try:
                scan = self._events.get(timeout=_IDLE)
            except queue.Empty:
                with self._lock:  # idle: end; the next event starts a new thread
                    if self._events.empty():
                        self._thread = None
                        return
                continue
            if not scan:
                return
            time.sleep(_SETTLE)  # let a constructor that is matching right now finish
            while not self._events.empty():  # one scan covers every event so far
                if not self._events.get():
                    return
            try:
                self._scan()
            except Exception:  # a peer vanishing mid-scan, the participant closing: never fatal
                log.debug("could not identify a mismatched peer", exc_info=True)

    def _scan(self) -> None:
        for entity in live_endpoints(self._dp):
            ep: Any = entity  # the binding's entities are untyped
            if isinstance(entity, DataReader):
                status = ep.get_requested_incompatible_qos_status()
                if status.total_count:
                    pubs = ep.get_matched_publications()
                    matched = {str(ep.get_matched_publication_data(h).key) for h in pubs}
                    self._report(ep, "writer", matched, status.last_policy_id)
            else:
                status = ep.get_offered_incompatible_qos_status()
                if status.total_count:
                    subs = ep.get_matched_subscriptions()
                    matched = {str(ep.get_matched_subscription_data(h).key) for h in subs}
                    self._report(ep, "reader", matched, status.last_policy_id)

    def _report(self, entity: Any, peer_kind: str, matched: set[str], policy_id: int) -> None:
        """Report the peer endpoints on ``entity``'s topic that it has not matched."""
        topic = entity.topic.name
        policy = POLICY_NAMES.get(policy_id, f"policy {policy_id}")
        for ep in self._read("publication" if peer_kind == "writer" else "subscription"):
            key = str(ep.key)
            if ep.topic_name != topic or key in matched or ep.participant_key == self._own:
                continue
            if _by_design(entity, ep):
                continue
            with self._lock:
                if key in self._seen:
                    continue
                self._seen.add(key)
            mismatch = PeerMismatch(topic, peer_kind, policy, ep.type_name, key, *self._participant(ep))
            with self._lock:
                self._found.append(mismatch)
            log.warning("%s", mismatch.message())

    def _read(self, which: str) -> list[Any]:
        from cyclonedds.builtin import (
            BuiltinDataReader,
            BuiltinTopicDcpsParticipant,
            BuiltinTopicDcpsPublication,
            BuiltinTopicDcpsSubscription,
        )

        topics = {
            "participant": BuiltinTopicDcpsParticipant,
            "publication": BuiltinTopicDcpsPublication,
            "subscription": BuiltinTopicDcpsSubscription,
        }
        if which not in self._builtin:
            self._builtin[which] = BuiltinDataReader(self._dp, topics[which])
        return list(self._builtin[which].read(N=100_000))

    def _participant(self, endpoint: Any) -> tuple[str, str, str]:
        """(host, pid, process name) of an endpoint's participant, "?" where it does not say."""
        from cyclonedds.qos import Policy

        for p in self._read("participant"):
            if p.key == endpoint.participant_key:
                props = {q.key: q.value for q in p.qos if isinstance(q, Policy.Property)}
                return props.get("__Hostname", "?"), props.get("__Pid", "?"), props.get("__ProcessName", "?")
        return "?", "?", "?"

