"""What a node answers a client, whatever carried it: its presence, a get's and a set's reply."""

from __future__ import annotations

from dataclasses import dataclass

from .history import HistoryRecord
from .results import GetResult, SetResult
from .revision import Revision
from .values import ParameterValue

__all__ = ["GetReply", "HistoryReply", "NodeInfo", "SetReply"]


class _At:
    """A node's state as a reply or a presence reports it (the dataclasses below)."""

    incarnation: int
    revision: int

    @property
    def at(self) -> Revision:
        """(incarnation, revision): what ``set(..., if_revision=)`` compares."""
        return Revision(self.incarnation, self.revision)


@dataclass(frozen=True)
class NodeInfo(_At):
    """A node as its presence reports it: online, where it runs, its revision and size."""

    node: str
    online: bool
    host: str
    pid: int
    revision: int
    parameters: int
    request_filter: str | None = None  # how the server filters requests: "native", "handler", or unsaid
    incarnation: int = 0  # the server's for this node (new on every start); 0 from one without
    origin: str | None = None  # where the node comes from (presence tag "origin", "ros2" for a mirror)
    status: str | None = None  # presence tag "status": "unreachable", "stale" (a mirror), else None


@dataclass(frozen=True)
class GetReply(_At):
    """A node's answer to a get: a result per name asked, at the node's revision."""

    node: str
    revision: int
    results: tuple[GetResult, ...]
    incarnation: int = 0

    def values(self) -> dict[str, ParameterValue]:
        """The values found, by name (unknown names are in :meth:`missing`)."""
        return {r.name: r.value for r in self.results if r.value is not None}

    def missing(self) -> list[GetResult]:
        return [r for r in self.results if r.code is not None]


@dataclass(frozen=True)
class SetReply(_At):
    """A node's answer to a set: a result per parameter, and the node's revision after it."""

    node: str
    revision: int
    results: tuple[SetResult, ...]
    incarnation: int = 0  # the node's (on CONFLICT: its current one, with revision)

    @property
    def successful(self) -> bool:
        return all(r.successful for r in self.results)


@dataclass(frozen=True)
class HistoryReply:
    """A node's history as asked: records oldest first; ``compacted``: retention dropped some
    of the range asked for, so the records are not its whole past."""

    node: str
    records: tuple[HistoryRecord, ...]
    compacted: bool = False
