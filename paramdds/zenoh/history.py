"""The past over Zenoh: the JSON of history queries and history pages.

Shapes (docs/zenoh.md repeats them), values in the tagged form of :mod:`.codec`:

* a history request (``.../history``): ``{"names": [...], "since_revision": n | null,
  "since_time_ns": n | null, "until_time_ns": n | null, "who": glob, "outcome": "all" |
  "applied" | "refused", "after_seq": n, "limit": n (at most and by default
  :data:`~paramdds.core.history.PAGE_SIZE`), "timeout": s}``;
* its reply: ``{"ok": true, "node", "kept": bool, "more": bool, "compacted": bool,
  "records": [record...]}``, a record ``{"seq", "node", "name", "revision", "time",
  "time_ns", "who", "verified", "via", "old", "new", "outcome", "code", "reason"}``
  (``old`` null: the parameter did not exist; ``new`` null: deleted). ``kept`` false:
  the node keeps no history. One page per query; the asker pages with ``after_seq``
  (the last record's ``seq``).

Pure: no Zenoh, no DDS.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..core.history import PAGE_SIZE, HistoryPage, HistoryQuery, HistoryRecord, Outcome
from ..errors import FileFormatError, ParamddsError
from .codec import dumps, time_ns_of, value_in, value_out

__all__ = [
    "history_reply",
    "page_of",
    "query_in",
    "query_out",
    "record_in",
    "record_out",
]

_OUTCOMES = {"all": Outcome.ALL, "applied": Outcome.APPLIED, "refused": Outcome.REFUSED}


# -- queries ---------------------------------------------------------------------------------


def _opt_int(obj: Mapping[str, Any], key: str) -> int | None:
    raw = obj.get(key)
    if raw is None:
        return None
    if isinstance(raw, bool) or not isinstance(raw, int):
        raise ParamddsError(f"{key!r} must be an integer or null, got {raw!r}")
    return raw


def query_out(q: HistoryQuery) -> dict[str, object]:
    """A history request's body (the asker adds its ``timeout``)."""
    return {
        "names": list(q.names),
        "since_revision": q.since_revision,
        "since_time_ns": q.since_time_ns,
        "until_time_ns": q.until_time_ns,
        "who": q.who,
        "outcome": q.outcome.name.lower(),
        "after_seq": q.after_seq,
        "limit": q.limit,
    }


def query_in(obj: Mapping[str, Any]) -> HistoryQuery:
    """The query a history request asks (ParamddsError saying what is wrong with a bad one)."""
    names = obj.get("names", [])
    if not isinstance(names, list):
        raise ParamddsError("'names' must be a list of parameter names")
    outcome = _OUTCOMES.get(str(obj.get("outcome", "all")))
    if outcome is None:
        raise ParamddsError(f"'outcome' must be one of {', '.join(_OUTCOMES)}, got {obj.get('outcome')!r}")
    return HistoryQuery(
        names=tuple(str(n) for n in names),
        since_revision=_opt_int(obj, "since_revision"),
        since_time_ns=_opt_int(obj, "since_time_ns"),
        until_time_ns=_opt_int(obj, "until_time_ns"),
        who=str(obj.get("who") or ""),
        outcome=outcome,
        after_seq=_opt_int(obj, "after_seq") or 0,
        limit=min(PAGE_SIZE, max(0, _opt_int(obj, "limit") or 0)),  # one reply stays one page
    )


# -- pages -----------------------------------------------------------------------------------


def record_out(r: HistoryRecord) -> dict[str, object]:
    return {
        **r.to_json(),
        "seq": r.seq,
        "time_ns": r.time_ns,
        "old": None if r.old is None else value_out(r.old),
        "new": None if r.new is None else value_out(r.new),
        "code": r.code,
    }


def record_in(obj: Mapping[str, Any]) -> HistoryRecord:
    return HistoryRecord(
        seq=int(obj["seq"]),
        node=str(obj["node"]),
        name=str(obj["name"]),
        revision=int(obj["revision"]),
        time_ns=time_ns_of(obj),
        who=str(obj.get("who") or ""),
        verified=bool(obj.get("verified")),
        via=str(obj.get("via") or ""),
        old=None if obj.get("old") is None else value_in(obj["old"]),
        new=None if obj.get("new") is None else value_in(obj["new"]),
        applied=obj.get("outcome", "applied") != "refused",
        code=str(obj.get("code") or ""),
        reason=str(obj.get("reason") or ""),
    )


def history_reply(node: str, page: HistoryPage, kept: bool) -> bytes:
    return dumps(
        {
            "ok": True,
            "node": node,
            "kept": kept,
            "more": page.more,
            "compacted": page.compacted,
            "records": [record_out(r) for r in page.records],
        }
    )


def page_of(obj: Mapping[str, Any]) -> tuple[HistoryPage, bool]:
    """(the page, whether the node keeps history) of a successful history reply."""
    try:
        records = tuple(record_in(r) for r in obj.get("records", []))
        page = HistoryPage(records, bool(obj.get("more")), bool(obj.get("compacted")))
        return page, bool(obj.get("kept", True))
    except (KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(f"a malformed history reply: {type(exc).__name__}: {exc}") from None
    except ParamddsError as exc:
        raise FileFormatError(f"a malformed history reply: {exc.message}") from None
