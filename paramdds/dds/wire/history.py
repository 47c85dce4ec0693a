"""History and blame between the core's classes and the wire types.

A history query rides a ``GetParametersRequest`` (its ``history`` member), its page
the ``GetParametersResponse`` (``history``, ``history_kept``, ``history_more``,
``history_compacted``); a parameter's last change rides ``GetParameterResult``.
Times are nanoseconds since the Unix epoch in the core, ``Time`` on the wire.
"""

from __future__ import annotations

from ...core.history import HistoryPage, HistoryQuery, HistoryRecord, Outcome
from ...core.results import LastChange
from . import types as wire
from .convert import value_from_wire, value_to_wire

__all__ = [
    "last_change_from_wire",
    "last_change_to_wire",
    "page_from_wire",
    "query_from_wire",
    "query_to_wire",
    "record_to_wire",
]

_NS = 1_000_000_000


def _time(ns: int) -> wire.Time:
    return wire.Time(sec=ns // _NS, nanosec=ns % _NS)


def _ns(t: wire.Time) -> int:
    return int(t.sec) * _NS + int(t.nanosec)


def query_to_wire(q: HistoryQuery) -> wire.HistoryQuery:
    return wire.HistoryQuery(
        since_revision=-1 if q.since_revision is None else q.since_revision,
        since_time=q.since_time_ns or 0,
        until_time=q.until_time_ns or 0,
        who=q.who,
        outcome=int(q.outcome),
        limit=q.limit,
        after_seq=q.after_seq,
    )


def query_from_wire(names: list[str], w: wire.HistoryQuery) -> HistoryQuery:
    """The query of a request (``names``: the request's, () for every parameter)."""
    try:
        outcome = Outcome(w.outcome)
    except ValueError:
        outcome = Outcome.ALL
    return HistoryQuery(
        names=tuple(names),
        since_revision=None if w.since_revision < 0 else int(w.since_revision),
        since_time_ns=int(w.since_time) or None,
        until_time_ns=int(w.until_time) or None,
        who=w.who,
        outcome=outcome,
        after_seq=int(w.after_seq),
        limit=int(w.limit),
    )


def record_to_wire(r: HistoryRecord) -> wire.HistoryRecord:
    return wire.HistoryRecord(
        seq=r.seq,
        name=r.name,
        revision=r.revision,
        stamp=_time(r.time_ns),
        who=r.who,
        verified=r.verified,
        via=r.via,
        old_value=[] if r.old is None else [value_to_wire(r.old)],
        new_value=[] if r.new is None else [value_to_wire(r.new)],
        applied=r.applied,
        code=r.code,
        reason=r.reason,
    )


def _record_from_wire(node: str, w: wire.HistoryRecord) -> HistoryRecord:
    return HistoryRecord(
        seq=int(w.seq),
        node=node,
        name=w.name,
        revision=int(w.revision),
        time_ns=_ns(w.stamp),
        who=w.who,
        verified=bool(w.verified),
        via=w.via,
        old=value_from_wire(w.old_value[0]) if w.old_value else None,
        new=value_from_wire(w.new_value[0]) if w.new_value else None,
        applied=bool(w.applied),
        code=w.code,
        reason=w.reason,
    )


def page_from_wire(response: wire.GetParametersResponse) -> tuple[bool, HistoryPage]:
    """Whether the node keeps history, and the page it answered."""
    records = tuple(_record_from_wire(response.node_id, r) for r in response.history)
    return bool(response.history_kept), HistoryPage(
        records, bool(response.history_more), bool(response.history_compacted)
    )


def last_change_to_wire(c: LastChange) -> wire.LastChange:
    return wire.LastChange(
        who=c.who, verified=c.verified, via=c.via, stamp=_time(c.time_ns), revision=c.revision
    )


def last_change_from_wire(w: wire.LastChange) -> LastChange:
    return LastChange(w.who, bool(w.verified), w.via, _ns(w.stamp), int(w.revision))
