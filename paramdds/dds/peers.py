"""Peers whose type or QoS does not match ours: reported loudly, once per peer endpoint.

A DDS peer that uses one of our topic names with another type (an old release,
an edited IDL, an ``@appendable`` copy) or an incompatible QoS (a best-effort
state writer, a volatile writer for a transient-local reader) is simply never
matched: without this module its requests would time out and its state would
never show, with nothing said anywhere.

Cyclone reports each such peer on our side as a status: REQUESTED_INCOMPATIBLE_QOS
on our reader, OFFERED_INCOMPATIBLE_QOS on our writer (a type mismatch is the
policy TYPE_CONSISTENCY_ENFORCEMENT, an unreadable encoding DATA_REPRESENTATION).
The status says which policy, not which peer. :meth:`PeerWatch.poll` adds up those
statuses' counts over the participant's readers and writers (a few status reads:
cheap enough for every tick of a dispatch loop); when the sum has grown, it wakes
a thread of the watch's own, which reads Cyclone's builtin discovery topics: the
endpoints on that topic name that are not matched with ours are the culprits, and
the participant they belong to gives the host, pid and process name. Each is
logged once, as a warning on the ``paramdds.peers`` logger, and kept in
:meth:`PeerWatch.mismatches`. :meth:`PeerWatch.check` does the same at once, on
the caller's thread (a client whose call is failing, a test).

Who polls: a server and a monitor from their dispatch loop's tick; a client when a
call fails (its TIMEOUT or UNAVAILABLE names the peers). No Cyclone listener is
installed: a listener's callbacks run on Cyclone's own receive and discovery
threads and must take the GIL, so every event (and a client's volatile set writer
meets a server's transient-local assignment reader, by design, at every start; an
assigner's transient-local answer reader meets every server's volatile set replies)
made discovery wait for whatever Python was doing; at 30 % packet loss that turned
a few fresh ``paramdds`` processes in a hundred into a 10 s TIMEOUT.
"""

from __future__ import annotations

import fnmatch
import logging
import queue
import threading
from dataclasses import dataclass
from typing import Any

from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader

from ._binding import entity_handle, live_endpoints, matched_publications, matched_subscriptions

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


def _durability(qos: Any) -> Any:
    from cyclonedds.qos import Policy

    if Policy.Durability in qos:  # the binding's Qos has no get()
        return qos[Policy.Durability]
    return Policy.Durability.Volatile


_ASSIGNED = frozenset({"SetParametersRequest", "SetParametersResponse"})
"""The topics that carry assignments and their answers beside the interactive sets."""


def _by_design(ours: Any, endpoint: Any) -> bool:
    """A volatile writer and a transient-local reader of an assignment topic, which do not match.

    By design: assignments and their answers ride the set topics beside interactive
    sets, with transient-local endpoints of their own. A server reads
    SetParametersRequest twice, interactive requests (volatile) and retained
    assignments (transient-local); an assigner reads its answers on
    SetParametersResponse through a transient-local reader, which every server's
    volatile reply writer meets. Each side sees the other as incompatible in DURABILITY.
    """
    from cyclonedds.qos import Policy

    mine, theirs = _durability(ours.get_qos()), _durability(endpoint.qos)
    return bool(
        ours.topic.name in _ASSIGNED
        and {mine, theirs} == {Policy.Durability.Volatile, Policy.Durability.TransientLocal}
    )


def _partitions(qos: Any) -> tuple[str, ...]:
    from cyclonedds.qos import Policy

    if Policy.Partition in qos:
        return tuple(qos[Policy.Partition].partitions) or ("",)
    return ("",)


def _partitions_meet(ours: Any, endpoint: Any) -> bool:
    """Whether ``ours`` and ``endpoint`` share a partition (a name on one side may be a glob):
    a writer in a partition a reader does not read is not its peer (a server's claims in the
    hosts partition; in secure mode, other nodes' partitions), whatever else they offer."""
    mine, theirs = _partitions(ours.get_qos()), _partitions(endpoint.qos)
    return any(a == b or fnmatch.fnmatchcase(a, b) or fnmatch.fnmatchcase(b, a) for a in mine for b in theirs)


def _meets_by_design(ours: Any) -> bool:
    """Whether ``ours`` is one side of the by-design mismatch (see :func:`_by_design`).

    Its statuses count every client (or server) it meets, so they are not polled: a
    server would look into each new client. A peer of another type on that topic still
    shows on the endpoints beside it (a server's interactive request reader, a client's
    get and list writers).
    """
    from cyclonedds.qos import Policy

    if ours.topic.name not in _ASSIGNED:
        return False
    wanted = Policy.Durability.TransientLocal if isinstance(ours, DataReader) else Policy.Durability.Volatile
    return bool(_durability(ours.get_qos()) == wanted)


class PeerWatch:
    """Reports mismatched peers of one participant (see the module doc)."""

    def __init__(self, participant: DomainParticipant) -> None:
        self._dp = participant
        self._own = participant.guid
        self._events: queue.SimpleQueue[bool] = queue.SimpleQueue()  # True: scan, False: stop
        self._lock = threading.Lock()
        self._scanning = threading.Lock()
        self._thread: threading.Thread | None = None
        self._builtin: dict[str, Any] = {}  # builtin readers, for the length of one scan
        self._seen: set[str] = set()
        self._found: list[PeerMismatch] = []
        self._counted = 0  # the incompatible-QoS counts already looked into
        self._polled: dict[int, bool] = {}  # endpoint handle -> whether its statuses are polled
        self._closed = False

    def mismatches(self) -> list[PeerMismatch]:
        """Every mismatched peer endpoint reported so far."""
        with self._lock:
            return list(self._found)

    def poll(self) -> None:
        """Look into new incompatible-QoS events on the watch's thread (cheap when there are none)."""
        if self._changed():
            self._wake()

    def check(self) -> list[PeerMismatch]:
        """Look into new incompatible-QoS events now, on this thread; every mismatch so far."""
        if self._changed():
            with self._scanning:
                self._scan_safely()
        return self.mismatches()

    def close(self) -> None:
        """Stop the thread (before the participant is deleted)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            thread = self._thread
        self._events.put(False)
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=2.0)

    def _changed(self) -> bool:
        total = 0
        try:
            for entity in live_endpoints(self._dp):
                ep: Any = entity  # the binding's entities are untyped
                handle = entity_handle(ep)
                if handle not in self._polled:
                    self._polled[handle] = not _meets_by_design(ep)
                if not self._polled[handle]:
                    continue
                if isinstance(entity, DataReader):
                    total += ep.get_requested_incompatible_qos_status().total_count
                else:
                    total += ep.get_offered_incompatible_qos_status().total_count
        except Exception:  # an endpoint deleted meanwhile, the participant closing
            log.debug("could not read the incompatible-QoS statuses", exc_info=True)
            return False
        with self._lock:
            if self._closed or total == self._counted:
                return False
            self._counted = total
            return True

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
            while not self._events.empty():  # one scan covers every event so far
                if not self._events.get():
                    return
            with self._scanning:
                self._scan_safely()

    def _scan_safely(self) -> None:
        try:
            self._scan()
        except Exception:  # a peer vanishing mid-scan, the participant closing: never fatal
            log.debug("could not identify a mismatched peer", exc_info=True)
        finally:
            self._drop_builtin()

    def _drop_builtin(self) -> None:
        """Delete the scan's builtin readers: kept, they would hold every endpoint that ever
        existed (a server meets a new client's by-design mismatch at each start)."""
        from cyclonedds.core import Entity

        readers, self._builtin = self._builtin, {}
        for reader in readers.values():
            Entity.__del__(reader)

    def _scan(self) -> None:
        for entity in live_endpoints(self._dp):
            ep: Any = entity  # the binding's entities are untyped
            if isinstance(entity, DataReader):
                status = ep.get_requested_incompatible_qos_status()
                if status.total_count:
                    pubs = matched_publications(ep)
                    matched = {str(ep.get_matched_publication_data(h).key) for h in pubs}
                    self._report(ep, "writer", matched, status.last_policy_id)
            else:
                status = ep.get_offered_incompatible_qos_status()
                if status.total_count:
                    subs = matched_subscriptions(ep)
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
            if _by_design(entity, ep) or not _partitions_meet(entity, ep):
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
