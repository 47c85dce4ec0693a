"""A client's walk through a node's history, page by page (the same for every transport).

A node answers a history query one page at a time (at most its page size, and
``more`` when records are left); :class:`HistoryPages` says what to ask next and
gathers the answer, so the synchronous and the asynchronous clients run the same
loop around their own calls.
"""

from __future__ import annotations

from dataclasses import replace
from datetime import datetime

from ..errors import NoHistoryError
from .call import HistoryRequest
from .history import HistoryPage, HistoryQuery, HistoryRecord, Outcome
from .replies import HistoryReply

__all__ = ["HistoryPages", "TimeArg", "to_ns"]

TimeArg = datetime | float | int | None  # a datetime, or seconds since the Unix epoch


def to_ns(t: TimeArg) -> int | None:
    """``t`` as nanoseconds since the Unix epoch (a naive datetime is local time)."""
    if t is None:
        return None
    if isinstance(t, datetime):
        return round(t.timestamp() * 1e9)
    return round(float(t) * 1e9)


class HistoryPages:
    """The requests of one history call and the reply they add up to."""

    def __init__(
        self,
        node: str,
        names: tuple[str, ...] = (),
        *,
        since_revision: int | None = None,
        since_time: TimeArg = None,
        until: TimeArg = None,
        who: str = "",
        outcome: Outcome = Outcome.ALL,
    ) -> None:
        self.node = node
        self.query = HistoryQuery(
            names, since_revision, to_ns(since_time), to_ns(until), who, Outcome(outcome)
        )
        self._records: list[HistoryRecord] = []
        self._compacted = False

    def request(self) -> HistoryRequest:
        """The next page to ask for."""
        return HistoryRequest(self.node, self.query)

    def take(self, kept: bool, page: HistoryPage) -> bool:
        """Add a page; True when it was the last. NoHistoryError if the node keeps none."""
        if not kept:
            raise NoHistoryError(f"node {self.node!r} keeps no history (a peer that does not record it)")
        self._records += page.records
        self._compacted |= page.compacted
        if page.more and page.records:
            self.query = replace(self.query, after_seq=page.records[-1].seq)
            return False
        return True

    def reply(self) -> HistoryReply:
        node = self._records[0].node if self._records else self.node
        return HistoryReply(node, tuple(self._records), self._compacted)
