"""The life of one client call, whatever carries it: what it asks, when to send it again, how it fails.

Pure (no I/O, no threads, no clock: every method is given ``now``), in the style of
h11: the client feeds a :class:`Call` what happened and the time, and the call says
what to do next. The rules:

* A call waits at most its ``timeout`` (plus the transport's ``grace``: the time a
  transport that bounds its one copy itself is given to say how that copy ended).
* A transport that resends is woken every ``match_poll`` seconds (a copy is sent at
  once to a peer matched since the last look) and after ``resend_after`` seconds
  without a reply, doubling up to :data:`MAX_RESEND` (a copy is sent again; before
  that, a node gone is a failure). A lost copy then costs a fraction of a second.
* A write that may have reached its node never fails as "not there": without an
  answer its outcome is unknown (OUTCOME_UNKNOWN), at the deadline or when the client
  is closed. A write whose copies went to a peer (:attr:`Call.may_apply`) may have
  reached its node unless the client is *sure* no server that took a copy hosted it:
* **Sure never to land** (:meth:`Call.lost`). A server takes a request only for a node
  it hosts, and publishes that node's presence (TRANSIENT_LOCAL) before it takes any
  request for it; requests are VOLATILE, so a server that matches later gets only the
  copies sent after. So a write is sure never to land when no server ever announced its
  node (it was ABSENT at every look, never ONLINE or OFFLINE) and the transport's
  discovery is *sure* (:class:`Mark`: every server matched has told its nodes; one
  excused as dead before it did may hold a copy), once the client has stopped sending
  it for :data:`IN_FLIGHT` seconds (a copy on its way, to a server that starts hosting
  the node meanwhile, would have brought that node's presence back by then). The call
  then *holds* (sends no copy, not even to a new peer) and fails NOT_SEEN. A node that
  was ever announced may hold a copy (offline can be a stalled process that resumes),
  so such a write still ends OUTCOME_UNKNOWN.
* Any other call fails NOT_SEEN as soon as its node is known gone (offline, or absent
  once discovery settled) at a discovery change or a resend, and at the deadline when
  the node is not online; else TIMEOUT.
* **A refusal from a later server life** (:meth:`Call.refused_by_a_later_life`) ends a
  compare-and-set of which more than one copy went out OUTCOME_UNKNOWN: a server answers
  a copy it already took from its reply cache, but a restarted server has none, so an
  earlier copy may have been applied by the life the write expected (killed between its
  commit and its reply), and the later life's refusal says nothing of that copy. Unless
  the answering life is known to have been serving the node when the first copy went
  out: then every copy went to it, and its refusal is true (a wrong expectation).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from enum import Enum
from typing import NamedTuple

from ..errors import OutcomeUnknownError, ParamddsError, UnavailableError
from .history import HistoryQuery
from .request import ParamsArg
from .revision import Revision

__all__ = [
    "IN_FLIGHT",
    "MAX_RESEND",
    "Call",
    "Failure",
    "GetRequest",
    "HistoryRequest",
    "ListRequest",
    "Mark",
    "Presence",
    "Request",
    "SetRequest",
    "Wake",
    "closed_error",
]

MAX_RESEND = 1.0  # seconds between two copies at most (a big, merely slow request is not resent often)
EARLY_END = 0.9  # a copy that ended without an answer before this share of the timeout: its route went
IN_FLIGHT = 0.5  # seconds after its last copy before a write is sure not to land (the discovery quiet period)


class Presence(str, Enum):
    """What a client can say about a node right now."""

    ONLINE = "online"  # its presence instance is alive
    OFFLINE = "offline"  # it was seen and has gone (instance not alive)
    ABSENT = "absent"  # never seen, and discovery has settled: it is not there
    UNKNOWN = "unknown"  # never seen, and discovery is still going on: it may yet appear


class Mark(NamedTuple):
    """A transport's discovery, as a call watches it."""

    settled: bool
    changes: Hashable  # what changes when a server dies
    # every server matched has told its nodes (none was excused as dead before it did):
    # "absent" then means no server that took a copy of a request hosted the node
    sure: bool = True


@dataclass(frozen=True)
class ListRequest:
    """Names and prefixes under ``prefixes``, ``depth`` levels deep (0: all)."""

    node: str
    prefixes: tuple[str, ...]
    depth: int
    write = False


@dataclass(frozen=True)
class GetRequest:
    """Values (and descriptors if asked) of ``names``."""

    node: str
    names: tuple[str, ...]
    with_descriptors: bool
    write = False


@dataclass(frozen=True)
class SetRequest:
    """Parameters to set, each on its own or all-or-nothing, maybe only at a revision."""

    node: str
    params: ParamsArg
    atomic: bool
    if_revision: int | Revision | None
    who: str = ""  # the asker's claimed identity
    via: str = ""  # the channel (core.origin.Via)
    write = True


@dataclass(frozen=True)
class HistoryRequest:
    """One page of a node's history (:class:`~paramdds.core.history.HistoryQuery`)."""

    node: str
    query: HistoryQuery
    write = False


Request = ListRequest | GetRequest | SetRequest | HistoryRequest


class Failure(Enum):
    """How a call without an answer ends (the transport words the error)."""

    NOT_SEEN = "not seen"  # its node is offline or absent, or was never seen while discovery went on
    NO_ROUTE = "no route"  # the transport's one copy ended early without an answer: the route went
    TIMEOUT = "timeout"  # a present node did not answer in time
    OUTCOME_UNKNOWN = "outcome unknown"  # a write that may have reached its node got no answer
    CLOSED = "closed"  # the client was closed while the call waited (nothing was applied)


class Wake(Enum):
    """Why a waiting call woke up."""

    RESEND = "resend"  # the resend timer ran out: look at the node, then send a copy
    POLL = "poll"  # a poll: send a copy only if the transport matched a new peer


@dataclass
class Call:
    """One call's schedule and what is known of it. ``resend_after`` None: never sent again."""

    node: str
    request_id: int
    write: bool
    timeout: float
    started: float
    resend_after: float | None = None
    match_poll: float = 0.02
    grace: float = 0.0
    reached: bool = False  # a copy went out while the transport had a peer for it
    announced: bool = False  # its node's presence was seen (online or offline) during the call
    in_flight: float = IN_FLIGHT
    holding: bool = False  # a write sure never to land as long as it sends no more copies: it sends none
    copies: int = 0  # copies sent that a peer may have taken
    _last_copy: float = field(default=float("-inf"), repr=False)
    _step: float = field(default=0.0, repr=False)
    _next_resend: float = field(default=0.0, repr=False)
    _seen: Mark | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.resend_after is not None:
            self._step = self.resend_after
            self._next_resend = self.started + self.resend_after

    @property
    def deadline(self) -> float:
        return self.started + self.timeout + self.grace

    @property
    def resends(self) -> bool:
        return self.resend_after is not None

    @property
    def may_apply(self) -> bool:
        """A write that went to a peer: without an answer, its outcome is unknown unless
        :meth:`lost` makes sure its node was never hosted by any of them."""
        return self.write and self.reached

    def sent(self, reached: bool, now: float | None = None) -> None:
        """A copy went out at ``now``; ``reached``: the transport had a peer for it then
        (``now`` None: when is not known, so the copy never counts as landed nowhere)."""
        self.reached = self.reached or reached
        if reached:
            self.copies += 1
            self._last_copy = float("inf") if now is None else now

    def saw(self, presence: Presence) -> None:
        """What a look at its node found (a presence instance: a server announced it)."""
        if presence is Presence.ONLINE or presence is Presence.OFFLINE:
            self.announced = True

    def waited(self, now: float) -> float:
        return now - self.started

    def expired(self, now: float) -> bool:
        return now >= self.deadline

    def wait(self, now: float) -> float:
        """How long to wait for the reply before waking up again."""
        if self.resend_after is None:
            return max(0.0, self.deadline - now)
        return max(0.0, min(self.deadline, self._next_resend, now + self.match_poll) - now)

    def wake(self, now: float) -> Wake:
        """Why the call woke at ``now`` (a RESEND moves the next one further, doubling)."""
        if self.resend_after is None or now < self._next_resend:
            return Wake.POLL
        self._step = min(2 * self._step, MAX_RESEND)
        self._next_resend = now + self._step
        return Wake.RESEND

    def watch(self, mark: Mark | None) -> None:
        """The transport's discovery when the call started (None: it does not watch yet)."""
        self._seen = mark

    def news(self, mark: Mark) -> bool:
        """Whether the call should look at its node now: discovery has just settled, or a
        server's liveliness changed (one died), since the last look. A write that may have
        reached a node that was announced waits on (the node may come back and answer)."""
        seen, self._seen = self._seen, mark
        if seen is None:
            news = mark.settled
        else:
            news = (mark.settled and not seen.settled) or mark.changes != seen.changes
        return news and not self._committed

    @property
    def _committed(self) -> bool:
        """A write that may have reached a node that was announced: no look can end it."""
        return self.may_apply and self.announced

    def lost(self, look: Callable[[], Presence], now: float) -> bool:
        """At a look at its node (a discovery change, a resend, any wake while it holds):
        whether the call fails NOT_SEEN now. ``look`` asks the transport for the node's
        presence. A read, or a write no peer took, fails once its node is offline or absent;
        a write a peer took only once it is sure never to land (see the module's rules),
        holding its copies until then."""
        if self._committed:
            return False
        presence = look()
        self.saw(presence)
        gone = presence is Presence.OFFLINE or presence is Presence.ABSENT
        if not self.may_apply or not gone:
            self.holding = False
            return gone
        sure = presence is Presence.ABSENT and self._seen is not None and self._seen.sure
        self.holding = sure and not self.announced
        return self.holding and now - self._last_copy >= self.in_flight

    def verdict(self, look: Callable[[], Presence], now: float) -> Failure:
        """How the call ends at its deadline (``look`` asks the transport, only when it
        resends: one that does not bounds its copy itself and knows no more)."""
        if self.may_apply:
            if self.resends and self.lost(look, now):
                return Failure.NOT_SEEN
            return Failure.OUTCOME_UNKNOWN
        if self.resends and look() is not Presence.ONLINE:
            return Failure.NOT_SEEN
        return Failure.TIMEOUT

    def unanswered(self, waited: float) -> Failure:
        """How the call ends when the transport's one copy ended after ``waited`` seconds
        without an answer: early, its route went (a sent write may have been applied)."""
        if self.may_apply:
            return Failure.OUTCOME_UNKNOWN
        return Failure.NO_ROUTE if waited < self.timeout * EARLY_END else Failure.TIMEOUT

    def refused_by_a_later_life(
        self, expected_life: int, answering_life: int, refused: bool, serving_life: int = 0
    ) -> bool:
        """Whether a write's refusal (``refused``) by server life ``answering_life`` leaves its
        outcome unknown: it expected life ``expected_life`` (a compare-and-set; 0: none), another
        answered, more than one copy went out (see the module's rules), and the answering life
        is not known to have served the node since the first copy (``serving_life``, 0: not
        known; a wrong expectation refused by the one life that got every copy is a true
        refusal)."""
        return (
            self.write
            and self.copies > 1
            and refused
            and 0 != expected_life != answering_life
            and serving_life != answering_life
        )

    def closed(self) -> Failure:
        """How the call ends when its client is closed while it waits."""
        return Failure.OUTCOME_UNKNOWN if self.may_apply else Failure.CLOSED


def closed_error(call: Call) -> ParamddsError:
    """The error of a call still waiting when its client is closed."""
    if call.closed() is Failure.OUTCOME_UNKNOWN:
        return OutcomeUnknownError(
            f"outcome unknown: the client was closed before node {call.node!r} answered; "
            "the request was sent and may have been applied"
        )
    return UnavailableError("the client was closed")

