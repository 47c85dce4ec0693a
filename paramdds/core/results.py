"""What the parameter table's operations return: results, outcomes and change sets.

Kept apart from ``table.py`` so that clients, which receive these over DDS,
need not import the table, its validation and its callbacks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone
from enum import Enum

from ..errors import ErrorCode
from .descriptors import ParameterDescriptor
from .origin import Origin, local_origin
from .values import ParameterValue


class ChangeKind(str, Enum):
    NEW = "new"
    CHANGED = "changed"
    DELETED = "deleted"


@dataclass(frozen=True, slots=True)
class ParameterChange:
    """One parameter's final state after a commit (``kind`` says new, changed or deleted)."""

    kind: ChangeKind
    name: str
    value: ParameterValue  # NOT_SET for DELETED
    descriptor: ParameterDescriptor
    old: ParameterValue | None = None  # its value before (None: it did not exist)


@dataclass(frozen=True, slots=True)
class ChangeSet:
    """What one committed request changed. ``revision`` goes up by one per commit.

    One change per parameter touched, carrying its final state, in the order the
    request first applied them; ``origin`` says who made it and through what,
    ``time_ns`` when (nanoseconds since the Unix epoch, 0: unknown).
    """

    node_id: str
    revision: int
    changes: tuple[ParameterChange, ...]
    origin: Origin = field(default_factory=local_origin)
    time_ns: int = 0


def iso_time(time_ns: int) -> str:
    """ISO 8601 UTC with microseconds: ``2026-11-29T01:02:03.456789Z``."""
    moment = datetime.fromtimestamp(time_ns / 1e9, tz=timezone.utc)
    return moment.strftime("%Y-%m-%dT%H:%M:%S.%fZ")


@dataclass(frozen=True, slots=True)
class LastChange:
    """Who last changed a parameter, whether verified, through what, when, at which revision."""

    who: str
    verified: bool
    via: str
    time_ns: int
    revision: int

    @classmethod
    def of(cls, change: ChangeSet) -> LastChange:
        o = change.origin
        return cls(o.who, o.verified, o.via_text, change.time_ns, change.revision)

    def to_json(self) -> dict[str, object]:
        """``{"who", "verified", "via", "time" (ISO 8601 UTC), "revision"}``."""
        return {
            "who": self.who,
            "verified": self.verified,
            "via": self.via,
            "time": iso_time(self.time_ns),
            "revision": self.revision,
        }


@dataclass(frozen=True, slots=True)
class SetResult:
    """What a set did to one parameter: applied, or refused with a code and a reason."""

    name: str
    successful: bool
    reason: str = ""  # kept on success too (an on-set callback may say why)
    code: ErrorCode | None = None  # None when successful


@dataclass(frozen=True, slots=True)
class SetOutcome:
    """What one set request did: a result per parameter, and what was committed."""

    results: tuple[SetResult, ...]
    revision: int  # the node's revision after this request
    change: ChangeSet | None  # None when nothing was committed


@dataclass(frozen=True, slots=True)
class GetResult:
    """One name of a get: its value (and descriptor if asked), or the code saying why not."""

    name: str
    value: ParameterValue | None  # None when not found
    descriptor: ParameterDescriptor | None  # only when asked for, and found
    code: ErrorCode | None = None  # NOT_FOUND / INVALID_NAME
    reason: str = ""
    last_change: LastChange | None = None  # with the descriptor, when the node knows it


@dataclass(frozen=True, slots=True)
class ListResult:
    """The names a list found, and the prefixes (namespaces) of those names."""

    names: tuple[str, ...]
    prefixes: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class SetVeto:
    """What an on-set callback returns: ``SetVeto(successful=False, reason=...)``."""

    successful: bool
    reason: str = ""
