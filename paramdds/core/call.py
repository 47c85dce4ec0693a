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
* A write that may have reached its node (:attr:`Call.may_apply`) never fails as
  "not there": without an answer its outcome is unknown (OUTCOME_UNKNOWN), at the
  deadline or when the client is closed.
* Any other call fails NOT_SEEN as soon as its node is known gone (offline, or absent
  once discovery settled) at a discovery change or a resend, and at the deadline when
  the node is not online; else TIMEOUT.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from enum import Enum

from ..errors import OutcomeUnknownError, ParamddsError, UnavailableError
from .request import ParamsArg
from .revision import Revision

__all__ = [
    "MAX_RESEND",
    "Call",
    "Failure",
    "GetRequest",
    "ListRequest",
    "Mark",
    "Request",
    "SetRequest",
    "Wake",
    "closed_error",
]

MAX_RESEND = 1.0  # seconds between two copies at most (a big, merely slow request is not resent often)
EARLY_END = 0.9  # a copy that ended without an answer before this share of the timeout: its route went

Mark = tuple[bool, Hashable]  # a transport's discovery, as (settled, what changes when a server dies)


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
    write = True


Request = ListRequest | GetRequest | SetRequest


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
        """A write that can have reached its node: without an answer, its outcome is unknown."""
        return self.write and self.reached

    def sent(self, reached: bool) -> None:
        """A copy went out; ``reached``: the transport had a peer for it then."""
        self.reached = self.reached or reached

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
        reached its node waits on (the node may come back and answer)."""
        seen, self._seen = self._seen, mark
        settled, liveliness = mark
        news = settled if seen is None else (settled and not seen[0]) or liveliness != seen[1]
        return news and not self.may_apply

    def lost(self, gone: Callable[[], bool]) -> bool:
        """At a resend: whether the call fails NOT_SEEN (``gone`` asks whether its node is
        offline or absent; a write that may have reached it is never lost)."""
        return not self.may_apply and gone()

    def verdict(self, online: Callable[[], bool]) -> Failure:
        """How the call ends at its deadline (``online`` asks the transport, only when it
        resends: one that does not bounds its copy itself and knows no more)."""
        if self.may_apply:
            return Failure.OUTCOME_UNKNOWN
        if self.resends and not online():
            return Failure.NOT_SEEN
        return Failure.TIMEOUT

    def unanswered(self, waited: float) -> Failure:
        """How the call ends when the transport's one copy ended after ``waited`` seconds
        without an answer: early, its route went (a sent write may have been applied)."""
        if self.may_apply:
            return Failure.OUTCOME_UNKNOWN
        return Failure.NO_ROUTE if waited < self.timeout * EARLY_END else Failure.TIMEOUT

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

