"""When may a client say a node is absent? What its participant knows about discovery.

A node is present when this client holds its presence instance (a ``ParameterEvents``
sample, TRANSIENT_LOCAL). Its *absence* cannot be observed, only inferred: on a
lossy link the participant of the node's server, its endpoints, or the historical
data of its state writer can arrive seconds after the client started. A fixed grace
period therefore either reports a node that is there as absent (lossy link) or makes
every answer about a ghost slow (healthy link).

The rule (:meth:`DiscoveryWatch.settled`): a node with no presence instance is
*absent* only once discovery has **settled**, which is when all three hold:

1. **something that could hold it was found**: at least one ``ParameterEvents``
   writer (local or remote: a parameter server) is matched to our presence reader.
   Before that nothing can be concluded, and the caller keeps waiting up to its own
   timeout (then it reports a timeout that says discovery found no server);
2. **every matched state writer that is alive has delivered**: each writer matched
   to the presence reader has delivered at least one sample to it (every server writes
   a presence instance per node it serves, so a matched writer that has delivered
   nothing still owes us its historical data), unless Cyclone reports it **not
   alive** (its liveliness lease ran out: a server asserts it every 0.25 s with a 1 s
   lease, so a killed one is not alive about a second after its death; see "Which
   writers are not alive" below). A killed process stays *matched* for its 10 s
   participant lease; before this exception its writer, if it died before delivering
   to a client that had just found it, held that client's discovery open for those
   10 s (so past any shorter call timeout);
3. **discovery is quiet**: nothing has changed for ``max(min_quiet, length of the
   current burst of changes)``: no participant appeared (builtin ``DCPSParticipant``
   reader), no endpoint matched on the presence reader or on the caller-supplied
   request/reply endpoints (a participant or endpoint that *leaves* brings nothing
   new: when it counted, fresh CLI processes running beside each other, each leaving
   after its call, kept each other's discovery unsettled for 1 to 2 s), no new ``ParameterEvents``
   *instance* arrived (updates of known instances do not count: a busy system, where
   some parameter changes every few milliseconds, still settles). The quiet period
   scales with how slowly discovery has gone: on a healthy link everything is known
   within milliseconds and the quiet period is ``min_quiet``; on a lossy one, where
   the last thing arrived 2 s after the first, the client waits another 2 s of
   silence before concluding anything. A burst starts at the watch's start, and
   again at the first change after a quiet period, so a long-lived client (a web
   console) that sees a new participant an hour later needs only ``min_quiet`` of
   silence after it, not an hour.

Asking again. A peer answers a *new* participant's announcement (SPDP) with its own,
four times, one second apart, and otherwise announces itself only every 8 s (Cyclone's
default: lease minus 2 s). On a link that drops 30 % of packets, all four answers
are lost for about one process in 120, which then learns of nobody for up to 8 s.
While no parameter server (state writer) is known and discovery has not settled, the
watch therefore creates a **probe**: an empty participant in the same domain (so the same
process and sockets) every :data:`PROBE_AFTER` seconds, at most :data:`MAX_PROBES`
times. Each probe is new to every peer, so each peer answers it four more times,
and since Cyclone keeps what it discovers per domain, not per participant, the
answer serves the client's own participant too. A probe costs a peer what one more
short-lived CLI process costs it; probes live until the watch is closed. The test is
"no server", not "nobody": fresh CLI processes running side by side know each other at
once (the same host), so with "no remote participant at all" as the test, a process
whose four answers from the server were lost would never ask again and would wait for
the server's next periodic announcement, 8 s later, and end in TIMEOUT "no parameter
server discovered yet (N remote participant(s) known)" (Cyclone traces of four such
processes at 50 % loss: none had received a single announcement from the server's
address, only from the other clients).

Which writers are not alive. Cyclone reports liveliness per reader, not per writer:
the reader's LIVELINESS_CHANGED status says how many matched writers are alive and
how many not (and only the *last* one to change, which does not identify them when
several change at once, as when a reader is created and matches every server at
once). A writer that has delivered is known alive while one of the instances it
delivered is alive (an instance goes NOT_ALIVE_NO_WRITERS when its writer's lease
runs out). So if ``not_alive`` writers are not alive and ``unsure`` of the delivered
writers are not known alive, at least ``not_alive - unsure`` of the pending writers
are not alive (:func:`owed`); when that covers them all, none is owed. Sound in the
conservative direction: a delivered server whose node is stalled (its presence
unregistered while the writer lives) counts as unsure, so a dead pending writer is
then still waited for (the call's timeout, or the dead participant's 10 s lease,
ends it), never the other way round; two servers hosting the same node id (warned
about) could make a dead one look alive, with the same outcome.
A change of liveliness is not a change of discovery for rule 3 (it says nothing new
will arrive), but it bumps :attr:`DiscoveryState.liveliness` so a waiting call looks
at its node's presence at once. The counts are read at each poll: nothing depends on
seeing each change separately.

The watch reads only sample *infos* of new ``ParameterEvents`` samples (never decodes
them) and only new participant samples, and does its work at most every
:data:`POLL_INTERVAL` seconds however often it is asked.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant
from cyclonedds.core import DDSException, Entity, InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.domain import DomainParticipant

from ..core.call import Presence
from ._binding import matched_publications, read_new_infos, take_participant_keys

log = logging.getLogger(__name__)

__all__ = [
    "MAX_PROBES",
    "MIN_QUIET",
    "POLL_INTERVAL",
    "PROBE_AFTER",
    "DiscoveryState",
    "DiscoveryWatch",
    "Presence",
    "is_quiet",
    "is_settled",
    "owed",
    "quiet_needed",
]

PROBE_AFTER = 3.5  # seconds without a parameter server before asking again (4 answers, 1 s apart)
MAX_PROBES = 3
MIN_QUIET = 0.5  # seconds of unchanged discovery before a node without presence counts as absent
POLL_INTERVAL = 0.05  # seconds: the watch refreshes at most this often
_NEW = SampleState.NotRead | ViewState.Any | InstanceState.Any
_BATCH = 4096  # infos read per call while catching up
_U64 = (1 << 64) - 1


def quiet_needed(burst: float, min_quiet: float) -> float:
    """Rule 3's silence: as long as the current burst of changes has lasted, at least ``min_quiet``."""
    return max(min_quiet, burst)


def owed(pending: int, not_alive: int, unsure: int) -> int:
    """How many of ``pending`` writers (matched, nothing delivered) may still be alive.

    ``not_alive`` is how many matched writers Cyclone reports not alive; ``unsure``
    how many of the *other* matched writers (those that have delivered) are not known
    to be alive. At least ``not_alive - unsure`` of the pending writers are therefore
    not alive, and owe nothing.
    """
    return pending - max(0, min(pending, not_alive - unsure))


def is_quiet(pending: int, burst: float, quiet_for: float, min_quiet: float) -> bool:
    """Rules 2 and 3: every writer found has delivered, and discovery has been quiet long enough
    (``burst`` is first to last change, ``quiet_for`` last change to now)."""
    return pending == 0 and quiet_for >= quiet_needed(burst, min_quiet)


def is_settled(writers: int, pending: int, burst: float, quiet_for: float, min_quiet: float) -> bool:
    """The rule of this module: a server was found (rule 1), and :func:`is_quiet`."""
    return writers > 0 and is_quiet(pending, burst, quiet_for, min_quiet)


@dataclass(frozen=True)
class DiscoveryState:
    """A snapshot of what the watch knows (seconds are counted from the watch's start)."""

    participants: int  # remote participants known now
    state_writers: int  # ParameterEvents writers matched to the presence reader
    pending_writers: int  # ... of which nothing has been delivered yet (not counting dead ones)
    last_change: float  # when discovery last changed
    burst: float  # how long the current burst of changes has lasted (first to last change)
    quiet_needed: float  # the silence rule 3 asks for, from last_change
    elapsed: float
    settled: bool
    # rules 2 and 3 without rule 1: no server need have been found. A process about to serve
    # nodes asks this before it takes any (its own writers left out with DiscoveryWatch.ignore):
    # "nobody else serves anything" is an answer
    quiet: bool = False
    dead_writers: int = 0  # writers that delivered nothing and are certainly not alive (see owed())
    liveliness: int = 0  # counts the liveliness changes seen: a waiting call re-checks its node when it moves

    def describe(self) -> str:
        """A short human account, for error messages."""
        if self.settled:
            done = (
                f"{self.dead_writers} not alive, the others delivered"
                if self.dead_writers
                else "all delivered"
            )
            return (
                f"discovery settled: {self.state_writers} parameter server writer(s) "
                f"from {self.participants} remote participant(s), {done}"
            )
        if self.state_writers == 0:
            return f"no parameter server discovered yet ({self.participants} remote participant(s) known)"
        if self.pending_writers:
            return (
                f"discovery in progress: {self.pending_writers} of {self.state_writers} "
                "server(s) still sending their state"
            )
        return f"discovery in progress: last change {self.elapsed - self.last_change:.1f} s ago"


class DiscoveryWatch:
    """Tracks discovery progress of one participant as seen by one presence reader.

    ``presence_reader`` is the client's ``ParameterEvents`` reader; ``endpoints`` are
    further readers/writers whose matches count as discovery progress (the client's
    request writers and reply readers). Thread-safe.
    """

    def __init__(
        self,
        participant: DomainParticipant,
        presence_reader: Any,
        endpoints: Sequence[Any] = (),
        *,
        min_quiet: float = MIN_QUIET,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._reader = presence_reader
        self._endpoints = list(endpoints)
        self._min_quiet = min_quiet
        self._clock = clock
        self._lock = threading.Lock()
        self._domain_id = participant.get_domain_id()
        self._own = {participant.guid}  # our participant and our probes
        self._probes: list[Any] = []
        self._participants = BuiltinDataReader(participant, BuiltinTopicDcpsParticipant)
        self._new_participants = ReadCondition(self._participants, _NEW)
        self._remote: set[Any] = set()
        self._arrivals = 0  # remote participants and state writers that appeared (leaving is no news)
        self._writers_seen: set[int] = set()
        self._ignored: set[int] = set()  # writers of this process not to wait for (see ignore())
        self._delivered: set[int] = set()  # publication handles that have delivered a sample
        self._instance_of: dict[int, int] = {}  # a delivering writer -> one instance it delivered
        self._not_alive = 0  # matched writers Cyclone reports not alive
        self._liveliness_changes = 0
        self._instances = 0
        self._signature: tuple[int, ...] = ()
        self._started = clock()
        self._last_change = self._started
        self._burst_start = self._started
        self._polled = float("-inf")
        self._closed = False
        self._state = self._snapshot(self._started, 0, 0)
        self._poll(self._started)  # what is known at creation (on loopback: usually everything)

    def state(self) -> DiscoveryState:
        """The current state (refreshed if the last refresh is older than :data:`POLL_INTERVAL`)."""
        with self._lock:
            now = self._clock()
            if now - self._polled >= POLL_INTERVAL and not self._closed:
                self._poll(now)
            return self._state

    def settled(self) -> bool:
        return self.state().settled

    def ignore(self, writer: Any) -> None:
        """Leave ``writer`` (a ``ParameterEvents`` writer of this participant) out of every rule.

        For a server created beside this watch that hosts nothing yet: it has nothing to
        deliver, so it would hold rule 2 open for ever.
        """
        with self._lock:
            self._ignored.add(writer.instance_handle & _U64)
            self._poll(self._clock())

    def _poll(self, now: float) -> None:
        self._polled = now
        self._read_participants()
        self._read_deliveries()
        self._read_liveliness()
        try:
            # the binding gives these handles signed, sample infos unsigned
            matched = {h & _U64 for h in matched_publications(self._reader)} - self._ignored
        except DDSException:
            matched = set()
        else:
            self._forget_unmatched(matched)
        self._arrivals += len(matched - self._writers_seen)
        self._writers_seen = matched
        matches = []
        for entity in self._endpoints:
            status = (
                entity.get_subscription_matched_status()
                if hasattr(entity, "get_subscription_matched_status")
                else entity.get_publication_matched_status()
            )
            matches.append(status.total_count)
        signature = (self._arrivals, self._instances, *matches)
        if signature != self._signature:
            burst = self._last_change - self._burst_start
            if now - self._last_change >= quiet_needed(burst, self._min_quiet):
                self._burst_start = now  # the first change after a quiet period starts a new burst
            self._signature = signature
            self._last_change = now
        waiting = matched - self._delivered
        dead = self._dead(matched, waiting)
        self._state = self._snapshot(now, len(matched), len(waiting) - dead, dead)
        if self._state.state_writers == 0 and not self._state.settled:
            self._maybe_probe(now)

    def _forget_unmatched(self, matched: set[int]) -> None:
        """Forget the writers that delivered and are matched no more: a writer delivers only
        once matched, and one that left never comes back (a writer found again is a new
        handle, and delivers again), so a long-lived client keeps nothing per server life."""
        gone = self._delivered - matched
        if gone:
            self._delivered -= gone
            for writer in gone:
                self._instance_of.pop(writer, None)

    def _maybe_probe(self, now: float) -> None:
        if len(self._probes) >= MAX_PROBES or now - self._started < PROBE_AFTER * (len(self._probes) + 1):
            return
        from cyclonedds.domain import DomainParticipant
        from cyclonedds.qos import Policy, Qos

        try:
            probe = DomainParticipant(self._domain_id, qos=Qos(Policy.EntityName("paramdds-probe")))
        except DDSException as exc:  # asking again is an optimisation: never fail a call for it
            log.debug("could not create a discovery probe: %s", exc)
            self._probes.append(None)  # counts against MAX_PROBES, so it is not retried every poll
            return
        self._own.add(probe.guid)
        self._probes.append(probe)

    def _read_liveliness(self) -> None:
        """Read the presence reader's LIVELINESS_CHANGED status (which resets its changes)."""
        try:
            status = self._reader.get_liveliness_changed_status()
        except DDSException:
            return
        if (
            status.alive_count_change
            or status.not_alive_count_change
            or status.not_alive_count != self._not_alive
        ):
            self._liveliness_changes += 1
        self._not_alive = status.not_alive_count

    def _dead(self, matched: set[int], pending: set[int]) -> int:
        """How many of the ``pending`` writers are certainly not alive (see :func:`owed`)."""
        if not pending or self._not_alive == 0:
            return 0
        unsure = 0
        for handle in matched - pending:
            if not self._known_alive(handle):
                unsure += 1
                if owed(len(pending), self._not_alive, unsure) == len(pending):
                    return 0
        return len(pending) - owed(len(pending), self._not_alive, unsure)

    def _known_alive(self, writer: int) -> bool:
        """Whether an instance ``writer`` delivered is alive (so the writer is, bar a twin)."""
        instance = self._instance_of.get(writer)
        if instance is None:
            return False
        try:
            samples = self._reader.read(N=1, instance_handle=instance)
        except DDSException:  # the instance is gone
            return False
        self._count(s.sample_info for s in samples)
        return bool(samples) and samples[0].sample_info.instance_state == InstanceState.Alive

    def _snapshot(self, now: float, writers: int, pending: int, dead: int = 0) -> DiscoveryState:
        burst = self._last_change - self._burst_start
        return DiscoveryState(
            participants=len(self._remote),
            state_writers=writers,
            pending_writers=pending,
            last_change=self._last_change - self._started,
            burst=burst,
            quiet_needed=quiet_needed(burst, self._min_quiet),
            elapsed=now - self._started,
            settled=is_settled(writers, pending, burst, now - self._last_change, self._min_quiet),
            quiet=is_quiet(pending, burst, now - self._last_change, self._min_quiet),
            dead_writers=dead,
            liveliness=self._liveliness_changes,
        )

    def _read_participants(self) -> None:
        for sample in take_participant_keys(self._participants, self._new_participants, _BATCH):
            key = getattr(sample, "key", None)
            if key is None or key in self._own:
                continue
            if sample.sample_info.instance_state == InstanceState.Alive:
                self._arrivals += key not in self._remote
                self._remote.add(key)
            else:
                self._remote.discard(key)

    def note_read(self, infos: Iterable[Any]) -> None:
        """Tell the watch about samples someone else read from the presence reader.

        Reading marks a sample read, so the watch's own pass (new samples only) would
        never see one the client read first: every other read of the presence reader
        passes its SampleInfos here.
        """
        with self._lock:
            self._count(infos)

    def _count(self, infos: Iterable[Any]) -> int:
        n = 0
        for info in infos:
            n += 1
            writer = info.publication_handle & _U64
            self._delivered.add(writer)
            self._instance_of.setdefault(writer, info.instance_handle)
            if info.sample_state == SampleState.NotRead and info.view_state == ViewState.New:
                self._instances += 1  # a node or parameter not seen before
        return n

    def _read_deliveries(self) -> None:
        while self._count(read_new_infos(self._reader, _NEW, _BATCH)) == _BATCH:
            pass

    @property
    def probes(self) -> int:
        """How many probe participants this watch has created."""
        return sum(1 for p in self._probes if p is not None)

    def close(self) -> None:
        """Delete the builtin reader and the probes this watch created."""
        with self._lock:
            if self._closed:
                return
            self._closed = True  # state() keeps answering with the last snapshot
            self._endpoints.clear()
            Entity.__del__(self._participants)
            while self._probes:
                probe = self._probes.pop()
                if probe is not None:
                    Entity.__del__(probe)
