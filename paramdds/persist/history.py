"""``FILE.history``: the nodes' history kept across restarts with ``--persist`` (every record,
each parameter's last change, and what retention dropped).

The records a node's worker persists ride in that group's journal line (``FILE.journal``:
one append and one ``fdatasync`` for the state and its history, before the replies). Each
compaction of the journal first moves them here: appended and fsynced, or, when this file
would hold over twice what retention keeps (plus :data:`REWRITE_SLACK`), rewritten with
only what it keeps (temporary file, fsync, rename). Only then is the journal truncated.

The first line is ``# paramdds history``; each further line is ``<crc32> <json>``, one of:

* ``["r", node, seq, name, revision, time_ns, who, verified, via, old, new, applied, code,
  reason]``: a record (``old``/``new``: ``[type, data]``, or null: did not exist / deleted);
* ``["l", node, {name: [who, verified, via, time_ns, revision]}]``: each existing
  parameter's last change (a rewrite writes it after the records it keeps: retention
  never drops a parameter's blame);
* ``["w", node, seq, revision, time_ns]``: the newest record retention dropped (the
  compacted watermark: a query reaching past it is told so).

Reading: this file's records, then the journal's; a record whose ``seq`` the node already
holds is one a crash during a compaction left in both, and is skipped. Retention applies
again with the time now. A torn or damaged last line is dropped (a crash during a
compaction's append: the journal still holds those records) and the file is rewritten at
the start; a bad line before the last is damage and refuses the start.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core.history import HistoryRecord, NodeHistory, Retention
from ..core.jsonform import value_of_row, value_row
from ..core.results import LastChange
from ..core.values import ParameterValue
from ..errors import ParamddsError
from ._files import PersistError, atomic_write, crc_line, decode_crc_line, fsync_directory

__all__ = ["REWRITE_SLACK", "HistoryFile", "StoredHistory", "record_of_row", "record_row"]

HISTORY_HEADER = b"# paramdds history\n"
REWRITE_SLACK = 10_000  # record lines beyond twice the retained before a rewrite


# -- rows --------------------------------------------------------------------------------------


def _value(v: ParameterValue | None) -> list[object] | None:
    return None if v is None else value_row(v)


def record_row(r: HistoryRecord) -> list[object]:
    """A record as the JSON list the journal and the history file carry (without its node)."""
    return [
        r.seq, r.name, r.revision, r.time_ns, r.who, r.verified, r.via,
        _value(r.old), _value(r.new), r.applied, r.code, r.reason,
    ]  # fmt: skip


class _Values:
    """Values of rows, each decoded once: a history repeats its values (each change's new
    value is the next one's old), and decoding is most of a reopen's time."""

    def __init__(self) -> None:
        self._seen: dict[object, ParameterValue] = {}

    def __call__(self, row: Any) -> ParameterValue | None:
        if row is None:
            return None
        t, data = row
        key = (t, type(data), tuple(data) if isinstance(data, list) else data)
        value = self._seen.get(key)
        if value is None:
            value = self._seen[key] = value_of_row(row)
        return value


def record_of_row(node: str, row: Sequence[object], values: _Values | None = None) -> HistoryRecord:
    """The record of a row of :func:`record_row` (ValueError/TypeError/ParamddsError if bad)."""
    seq, name, revision, time_ns, who, verified, via, old, new, applied, code, reason = row
    value = values or _Values()
    return HistoryRecord(
        int(seq), node, str(name), int(revision), int(time_ns), str(who), bool(verified),  # type: ignore[call-overload]
        str(via), value(old), value(new), bool(applied), str(code), str(reason),
    )  # fmt: skip


def _last_row(c: LastChange) -> list[object]:
    return [c.who, c.verified, c.via, c.time_ns, c.revision]


def _last_of_row(row: Sequence[object]) -> LastChange:
    who, verified, via, time_ns, revision = row
    return LastChange(str(who), bool(verified), str(via), int(time_ns), int(revision))  # type: ignore[call-overload]


# -- what one node keeps -----------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class StoredHistory:
    """One node's persisted history: what :meth:`NodeHistory.restore` takes back."""

    records: tuple[HistoryRecord, ...] = ()
    last: Mapping[str, LastChange] = field(default_factory=dict)
    dropped_seq: int = 0
    dropped_revision: int = -1
    dropped_time_ns: int = 0

    def restore_into(self, history: NodeHistory, names: Iterable[str] | None = None) -> None:
        """Give ``history`` these records and last changes (only those of ``names`` when
        given: the parameters the node has now)."""
        last = dict(self.last)
        if names is not None:
            keep = set(names)
            last = {n: c for n, c in last.items() if n in keep}
        history.restore(
            self.records,
            last,
            dropped_seq=self.dropped_seq,
            dropped_revision=self.dropped_revision,
            dropped_time_ns=self.dropped_time_ns,
        )


class _Kept:
    """One node's retained records (each with its line, so a rewrite encodes nothing), last
    changes and dropped watermark."""

    __slots__ = ("dropped", "last", "lines", "records", "top")

    def __init__(self) -> None:
        self.records: deque[HistoryRecord] = deque()
        self.lines: deque[bytes] = deque()  # the file line of each record
        self.last: dict[str, LastChange | HistoryRecord] = {}  # a record: its change is the last
        self.dropped = (0, -1, 0)  # seq, revision, time_ns
        self.top = 0  # the highest seq seen (dropped or kept)

    def add(self, r: HistoryRecord, line: bytes) -> bool:
        """Keep ``r`` and its file ``line``; False when its seq is not new (a duplicate)."""
        if r.seq <= self.top:
            return False
        self.top = r.seq
        self.records.append(r)
        self.lines.append(line)
        if r.applied:
            if r.new is None:
                self.last.pop(r.name, None)
            else:
                self.last[r.name] = r
        return True

    def drop_upto(self, seq: int, revision: int, time_ns: int) -> None:
        s, rev, t = self.dropped
        self.dropped = (max(s, seq), max(rev, revision), max(t, time_ns))
        self.top = max(self.top, seq)

    def trim(self, keep: Retention, now_ns: int) -> None:
        oldest = now_ns - int(keep.max_age_s * 1e9)
        records = self.records
        while records and (len(records) > keep.max_records or records[0].time_ns < oldest):
            gone = records.popleft()
            self.lines.popleft()
            self.drop_upto(gone.seq, gone.revision, gone.time_ns)

    def last_changes(self) -> dict[str, LastChange]:
        return {n: c if isinstance(c, LastChange) else _last_of(c) for n, c in self.last.items()}

    def stored(self) -> StoredHistory:
        seq, revision, time_ns = self.dropped
        return StoredHistory(tuple(self.records), self.last_changes(), seq, revision, time_ns)


def _last_of(r: HistoryRecord) -> LastChange:
    return LastChange(r.who, r.verified, r.via, r.time_ns, r.revision)


# -- the file ----------------------------------------------------------------------------------


class HistoryFile:
    """``FILE.history`` and what every node of the server keeps (not thread-safe: the
    :class:`~paramdds.persist.PersistStore` calls it under its lock)."""

    def __init__(self, path: Path, retention: Retention | None = None) -> None:
        self.path = path
        self.retention = retention or Retention()
        self._nodes: dict[str, _Kept] = {}
        self._pending: list[bytes] = []  # lines of records the journal holds, not this file yet
        self._lines = 0  # record lines in the file
        self._rewrite = False  # the file must be rewritten at the next checkpoint
        self.loaded = False

    def _kept(self, node: str) -> _Kept:
        kept = self._nodes.get(node)
        if kept is None:
            kept = self._nodes[node] = _Kept()
        return kept

    def load(self, journal_rows: Mapping[str, Sequence[Sequence[object]]]) -> None:
        """Read the file, then the records of the journal that follow it."""
        values = _Values()
        self._read_file(values)
        for node, rows in journal_rows.items():
            kept = self._kept(node)
            for row in rows:
                try:
                    record = record_of_row(node, row, values)
                except (ValueError, TypeError, ParamddsError) as exc:
                    raise PersistError(
                        f"bad history record in the journal: {exc}", file=str(self.path)
                    ) from exc
                line = crc_line(["r", node, *row])
                if kept.add(record, line):
                    self._pending.append(line)
        now = time.time_ns()
        for kept in self._nodes.values():
            kept.trim(self.retention, now)
        self.loaded = True

    def _read_file(self, values: _Values) -> None:
        try:
            raw = self.path.read_bytes()
        except FileNotFoundError:
            return
        except OSError as exc:
            raise PersistError(f"cannot read: {exc.strerror}", file=str(self.path)) from exc
        if not raw.startswith(HISTORY_HEADER):
            if HISTORY_HEADER.startswith(raw):  # cut while it was created
                self._rewrite = True
                return
            raise PersistError(
                "not a paramdds history file (it lacks our first line)", file=str(self.path)
            )
        lines = raw[len(HISTORY_HEADER) :].split(b"\n")
        if lines.pop():
            self._rewrite = True  # a torn last line: the journal still holds those records
        for number, line in enumerate(lines, start=2):
            item = decode_crc_line(line)
            try:
                if not isinstance(item, list) or len(item) < 2:
                    raise ValueError("not a history line")
                self._take(item, line + b"\n", values)
            except (ValueError, TypeError, ParamddsError) as exc:
                if number == len(lines) + 1:
                    self._rewrite = True  # a damaged last line, as a torn one
                    break
                raise PersistError(
                    f"a history line is damaged ({exc})", file=str(self.path), line=number
                ) from None

    def _take(self, item: list[object], line: bytes, values: _Values) -> None:
        kind, node = item[0], str(item[1])
        kept = self._kept(node)
        if kind == "r":
            if kept.add(record_of_row(node, item[2:], values), line):
                self._lines += 1
        elif kind == "l":
            rows = item[2]
            if not isinstance(rows, dict):
                raise ValueError("last changes are not a mapping")
            kept.last = {str(name): _last_of_row(row) for name, row in rows.items()}
        elif kind == "w":
            seq, revision, time_ns = (int(v) for v in item[2:5])  # type: ignore[call-overload]
            kept.drop_upto(seq, revision, time_ns)
        else:
            raise ValueError(f"unknown line kind {kind!r}")

    def add(self, node: str, records: Sequence[HistoryRecord]) -> list[list[object]]:
        """Keep ``records`` (new ones of ``node``, in seq order); their rows for the journal."""
        kept = self._kept(node)
        rows = []
        for r in records:
            row = record_row(r)
            rows.append(row)
            line = crc_line(["r", node, *row])
            if kept.add(r, line):
                self._pending.append(line)
        kept.trim(self.retention, max(time.time_ns(), records[-1].time_ns if records else 0))
        return rows

    def stored(self, node: str) -> StoredHistory:
        """What ``node`` keeps (empty when it has no history yet)."""
        kept = self._nodes.get(node)
        return kept.stored() if kept is not None else StoredHistory()

    def nodes(self) -> list[str]:
        return sorted(self._nodes)

    def checkpoint(self) -> None:
        """Make the file hold every record the journal holds (before it is truncated)."""
        retained = sum(len(k.records) for k in self._nodes.values())
        if self._rewrite or self._lines + len(self._pending) > 2 * retained + REWRITE_SLACK:
            self.rewrite()
        elif self._pending:
            self._append(b"".join(self._pending))
            self._lines += len(self._pending)
        self._pending = []

    def rewrite(self) -> None:
        """Replace the file with what retention keeps."""
        out = [HISTORY_HEADER]
        for node, kept in sorted(self._nodes.items()):
            out += kept.lines
            out.append(crc_line(["l", node, {n: _last_row(c) for n, c in kept.last_changes().items()}]))
            if kept.dropped[0]:
                out.append(crc_line(["w", node, *kept.dropped]))
        atomic_write(self.path, b"".join(out))
        self._lines = sum(len(k.records) for k in self._nodes.values())
        self._pending = []
        self._rewrite = False

    def _append(self, data: bytes) -> None:
        created = not self.path.exists()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            if created:
                data = HISTORY_HEADER + data
            written = 0
            while written < len(data):
                written += os.write(fd, data[written:])
            os.fsync(fd)
        except BaseException:
            self._rewrite = True  # a part may have reached the file: write it whole next time
            raise
        finally:
            os.close(fd)
        if created:
            fsync_directory(self.path.parent)
