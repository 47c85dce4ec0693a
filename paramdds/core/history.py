"""A node's past: every change it applied and every write it refused, with who and when.

:class:`NodeHistory` keeps one node's records in memory, oldest first, each numbered by
``seq`` (1, 2, … in order; a restore continues the count). Retention bounds it by count
and by age (:class:`Retention`); what it drops is remembered as a watermark, so a query
whose range reaches past it is answered with ``compacted`` (as etcd says "compacted"):
the answer is never passed off as the whole past. It also keeps each parameter's last
change (:class:`LastChange`), which retention never drops while the parameter exists:
that is the blame a node publishes with every value.

Pure logic: the server feeds it the :class:`~.results.ChangeSet` s its node commits
(:meth:`NodeHistory.applied`) and the writes it refuses (:meth:`NodeHistory.refused`),
and answers history queries with :meth:`NodeHistory.query`. :func:`rewind` rebuilds a
node's values as they were at a revision or a time from its values now and its records
since.
"""

from __future__ import annotations

import fnmatch
import itertools
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import NamedTuple

from .jsonform import json_value
from .origin import Origin
from .results import ChangeKind, ChangeSet, LastChange, iso_time
from .values import ParameterValue

__all__ = [
    "DEFAULT_MAX_AGE_S",
    "DEFAULT_MAX_RECORDS",
    "PAGE_SIZE",
    "HistoryPage",
    "HistoryQuery",
    "HistoryRecord",
    "LastChange",
    "NodeHistory",
    "Outcome",
    "Retention",
    "iso_time",
    "rewind",
]

DEFAULT_MAX_RECORDS = 10_000  # per node
DEFAULT_MAX_AGE_S = 30 * 24 * 3600.0  # 30 days
PAGE_SIZE = 500  # records per reply, at most


class Outcome(IntEnum):
    """Which records a query asks for."""

    ALL = 0
    APPLIED = 1
    REFUSED = 2


class HistoryRecord(NamedTuple):
    """One change a node applied to one parameter (``applied``), or one write it refused.

    ``old`` None: the parameter did not exist; ``new`` None: it was deleted (for a refusal,
    ``new`` is the value asked, ``code`` and ``reason`` say why). ``revision`` is the
    change's; a refusal's is the node's revision at the time. (A named tuple: a node makes
    one per parameter it changes, on its commit path.)"""

    seq: int
    node: str
    name: str
    revision: int
    time_ns: int
    who: str
    verified: bool
    via: str
    old: ParameterValue | None
    new: ParameterValue | None
    applied: bool = True
    code: str = ""
    reason: str = ""

    def to_json(self) -> dict[str, object]:
        """The record as ``history -o json`` prints it."""
        return {
            "node": self.node,
            "name": self.name,
            "revision": self.revision,
            "time": iso_time(self.time_ns),
            "who": self.who,
            "verified": self.verified,
            "via": self.via,
            "old": json_value(self.old),
            "new": json_value(self.new),
            "outcome": "applied" if self.applied else "refused",
            "reason": self.reason,
        }


@dataclass(frozen=True, slots=True)
class HistoryQuery:
    """Which records to return: those after ``after_seq`` that match every filter given."""

    names: tuple[str, ...] = ()  # exact names; () every parameter
    since_revision: int | None = None  # records with a revision above it
    since_time_ns: int | None = None  # records at or after it
    until_time_ns: int | None = None  # records at or before it
    who: str = ""  # a glob on who ("" anyone)
    outcome: Outcome = Outcome.ALL
    after_seq: int = 0  # records after this one (paging)
    limit: int = 0  # records per page at most (0: PAGE_SIZE)

    def matches(self, r: HistoryRecord) -> bool:
        if r.seq <= self.after_seq:
            return False
        if self.names and r.name not in self.names:
            return False
        if self.since_revision is not None and r.revision <= self.since_revision:
            return False
        if self.since_time_ns is not None and r.time_ns < self.since_time_ns:
            return False
        if self.until_time_ns is not None and r.time_ns > self.until_time_ns:
            return False
        if self.outcome is Outcome.APPLIED and not r.applied:
            return False
        if self.outcome is Outcome.REFUSED and r.applied:
            return False
        return not self.who or fnmatch.fnmatchcase(r.who, self.who)


@dataclass(frozen=True, slots=True)
class HistoryPage:
    """One answer to a query: records in order, whether more match, whether some were dropped."""

    records: tuple[HistoryRecord, ...]
    more: bool = False
    compacted: bool = False


@dataclass(frozen=True, slots=True)
class Retention:
    """How much of a node's past is kept: the newest ``max_records``, none older than ``max_age_s``."""

    max_records: int = DEFAULT_MAX_RECORDS
    max_age_s: float = DEFAULT_MAX_AGE_S


@dataclass(slots=True)
class _Dropped:
    """The newest record retention dropped (seq 0: none yet)."""

    seq: int = 0
    revision: int = -1
    time_ns: int = 0


@dataclass(slots=True)
class _State:
    records: deque[HistoryRecord] = field(default_factory=deque)
    last: dict[str, LastChange] = field(default_factory=dict)
    next_seq: int = 1
    dropped: _Dropped = field(default_factory=_Dropped)
    # the first seq of this server's life: the records before it were restored from an earlier
    # life (``--persist``), whose revisions counted from 1 as this one's do
    life_seq: int = 1


class NodeHistory:
    """One node's records and its parameters' last changes (thread-safe)."""

    def __init__(self, node_id: str, retention: Retention | None = None) -> None:
        self.node_id = node_id
        self.retention = retention or Retention()
        self._s = _State()
        self._lock = threading.Lock()
        self._listeners: list[Callable[[list[HistoryRecord]], None]] = []

    def add_listener(self, fn: Callable[[list[HistoryRecord]], None]) -> None:
        """Call ``fn(records)`` with every batch of new records, in order, on the recording
        thread, after they are kept (a store that persists them)."""
        self._listeners.append(fn)

    def _tell(self, records: list[HistoryRecord]) -> None:
        for fn in list(self._listeners) if records else []:
            fn(records)

    # -- recording ------------------------------------------------------------------

    def applied(self, change: ChangeSet) -> list[HistoryRecord]:
        """Record a committed change set: one record per parameter; returns them."""
        # the hot path of every commit: one record per parameter, made inline (~1 µs each)
        last = LastChange.of(change)
        node, revision, t, who, verified, via = (
            self.node_id, change.revision, change.time_ns, last.who, last.verified, last.via
        )
        deleted = ChangeKind.DELETED
        s = self._s
        with self._lock:
            seq = s.next_seq
            out = [
                HistoryRecord(
                    seq + i, node, c.name, revision, t, who, verified, via, c.old,
                    None if c.kind is deleted else c.value,
                )
                for i, c in enumerate(change.changes)
            ]  # fmt: skip
            s.next_seq = seq + len(out)
            s.records.extend(out)
            for c in change.changes:
                if c.kind is deleted:
                    s.last.pop(c.name, None)
                else:
                    s.last[c.name] = last
            self._trim(t)
        if self._listeners:
            self._tell(out)
        return out

    def started(
        self, values: Iterable[tuple[str, ParameterValue]], revision: int, origin: Origin, time_ns: int
    ) -> list[HistoryRecord]:
        """Record the values a node starts with (``via`` start), for each parameter whose last
        change is not known already (a restored history knows it); returns the new records."""
        author = _author(origin)
        last = LastChange(*author, time_ns, revision)
        with self._lock:
            out = []
            for name, value in values:
                if name not in self._s.last:
                    out.append(self._add(name, revision, time_ns, author, None, value))
                    self._s.last[name] = last
            self._trim(time_ns)
        self._tell(out)
        return out

    def refused(
        self,
        origin: Origin,
        revision: int,
        refusals: Iterable[tuple[str, ParameterValue | None, ParameterValue | None, str, str]],
        time_ns: int | None = None,
    ) -> list[HistoryRecord]:
        """Record refused writes: ``(name, value now, value asked, code, reason)`` each; returns them."""
        now = time.time_ns() if time_ns is None else time_ns
        author = _author(origin)
        with self._lock:
            out = [
                self._add(name, revision, now, author, old, new, applied=False, code=code, reason=reason)
                for name, old, new, code, reason in refusals
            ]
            self._trim(now)
        self._tell(out)
        return out

    def _add(
        self,
        name: str,
        revision: int,
        time_ns: int,
        author: tuple[str, bool, str],
        old: ParameterValue | None,
        new: ParameterValue | None,
        *,
        applied: bool = True,
        code: str = "",
        reason: str = "",
    ) -> HistoryRecord:
        who, verified, via = author
        record = HistoryRecord(
            self._s.next_seq, self.node_id, name, revision, time_ns, who, verified, via, old, new,
            applied, code, reason,
        )  # fmt: skip
        self._s.next_seq += 1
        self._s.records.append(record)
        return record

    def _trim(self, now_ns: int) -> None:
        records, keep = self._s.records, self.retention
        oldest = now_ns - int(keep.max_age_s * 1e9)
        while records and (len(records) > keep.max_records or records[0].time_ns < oldest):
            gone = records.popleft()
            d = self._s.dropped
            d.seq = gone.seq
            d.revision, d.time_ns = max(d.revision, gone.revision), max(d.time_ns, gone.time_ns)

    def restore(
        self,
        records: Iterable[HistoryRecord],
        last: Mapping[str, LastChange],
        *,
        dropped_seq: int = 0,
        dropped_revision: int = -1,
        dropped_time_ns: int = 0,
    ) -> None:
        """Take back what a persisted history held (a restart): records oldest first, then
        the count goes on after the highest seq."""
        with self._lock:
            s = self._s
            s.records = deque(records)
            s.last = dict(last)
            s.dropped = _Dropped(dropped_seq, dropped_revision, dropped_time_ns)
            top = s.records[-1].seq if s.records else dropped_seq
            s.next_seq = s.life_seq = max(s.next_seq, top + 1)
            self._trim(time.time_ns())

    # -- reading --------------------------------------------------------------------

    def last(self, name: str) -> LastChange | None:
        """The last change of ``name`` (None: unknown, or it does not exist)."""
        return self._s.last.get(name)

    def last_changes(self) -> dict[str, LastChange]:
        with self._lock:
            return dict(self._s.last)

    @property
    def next_seq(self) -> int:
        return self._s.next_seq

    def __len__(self) -> int:
        return len(self._s.records)

    def query(self, q: HistoryQuery) -> HistoryPage:
        """The records matching ``q``, oldest first, one page at most. A revision counts in
        this server's life: ``since_revision`` skips the records of earlier lives."""
        limit = q.limit if q.limit > 0 else PAGE_SIZE
        with self._lock:
            floor = 0 if q.since_revision is None else self._s.life_seq  # the first seq asked for
            found: list[HistoryRecord] = []
            more = False
            start = self._first_after(max(q.after_seq, floor - 1))
            for r in itertools.islice(self._s.records, start, None):
                if r.seq >= floor and q.matches(r):
                    if len(found) == limit:
                        more = True
                        break
                    found.append(r)
            return HistoryPage(tuple(found), more, self._compacted(q))

    def _first_after(self, seq: int) -> int:
        """The index of the first record after ``seq``, or one before it: a page's query starts
        there instead of rescanning the pages before (records are in seq order; their seqs are
        consecutive unless a restore gave gaps, then the scan starts earlier)."""
        records = self._s.records
        if not records or seq < records[0].seq:
            return 0
        i = min(seq - records[0].seq + 1, len(records))
        while i > 0 and records[i - 1].seq > seq:  # gaps put the seqs further than their index
            i -= 1
        return i

    def _compacted(self, q: HistoryQuery) -> bool:
        """Whether retention dropped records the query's range covers."""
        d = self._s.dropped
        if d.seq == 0 or q.after_seq >= d.seq:
            return False
        if q.since_revision is not None and (q.since_revision >= d.revision or d.seq < self._s.life_seq):
            return False  # the revision asked for is older than the drop, or the drop in an earlier life
        return q.since_time_ns is None or q.since_time_ns <= d.time_ns


def _author(origin: Origin) -> tuple[str, bool, str]:
    """(who, verified, via as text) of an origin."""
    return origin.who, origin.verified, origin.via_text


def rewind(
    now: Mapping[str, ParameterValue], since: Sequence[HistoryRecord]
) -> dict[str, ParameterValue]:
    """A node's values before the changes ``since`` (its records after the point wanted, in
    any order), from its values ``now``: each applied change is undone, newest first."""
    values = dict(now)
    for r in sorted((r for r in since if r.applied), key=lambda r: r.seq, reverse=True):
        if r.old is None:
            values.pop(r.name, None)
        else:
            values[r.name] = r.old
    return values
