"""``paramdds bench history-store``: where a node's history is kept with ``--persist``, measured
two ways: in the journal (the records of a commit group ride in its journal line; a compaction
moves them to ``FILE.history``: what ``--persist`` does), and in SQLite from the standard
library (WAL mode, ``synchronous=FULL``, one transaction per group, beside the journal that
still holds the state).

* **Cost per change, durable before the reply**: the persist call of a node's worker for
  groups of 1 and 8 changes (one parameter each), timed per call and divided by the group:
  the state alone (the journal as it was: the baseline), the state with its history in the
  journal, and the state in the journal with the history in SQLite. The three take turns
  (``--rounds``, default 3); ``--requests`` changes each (default 2,000).
* **Queries at ``--records`` records** (default 1,000,000; 100 nodes x 10,000 records, the
  default retention, and one node holding them all): by node and name, by time range (1 % of
  the span), by a who glob; every page of the answer. The journal's store answers from the
  nodes' memory (what a server does after reading ``FILE.history`` at its start); SQLite
  with indexes on (node, seq), (node, name, seq) and (node, time). Reopen: reading the whole
  history (the journal's ``FILE.history``; SQLite's rows into memory) and SQLite's open and
  last changes only.
* **Recovery after ``kill -9``**: a child process writes one change at a time and prints
  each acknowledged seq; it is killed with SIGKILL after 0.2-1 s (``--rounds`` times per
  store), the store is reopened: every acknowledged record must be there, the files must
  read without error (SQLite: ``PRAGMA integrity_check``), and the reopen is timed. A
  SIGKILL leaves the page cache to the kernel: this checks framing and recovery, not a
  power cut.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..core.history import HistoryQuery, HistoryRecord, NodeHistory, Retention
from ..core.jsonform import value_row
from ..core.origin import Origin, Via, acting
from ..core.results import ChangeSet
from ..core.table import ParameterTable
from ..core.values import Parameter, ParameterValue
from ..formats.files import dump_text, parse_ros_text
from ..persist import PersistStore, Snapshot
from ..persist.history import HistoryFile
from ..server_process import persist_store
from ._common import alternate, emit, median, note, render

NODE = "bench_history"
AUTHORS = [f"user{i}@host{i % 3}" for i in range(20)]


# -- SQLite, the other candidate ------------------------------------------------------------------

SCHEMA = """
create table if not exists history(
  node text not null, seq integer not null, name text not null, revision integer not null,
  time_ns integer not null, who text not null, verified integer not null, via text not null,
  old text, new text, applied integer not null, code text not null, reason text not null,
  primary key (node, seq)) without rowid;
create index if not exists history_name on history(node, name, seq);
create index if not exists history_time on history(node, time_ns);
"""


def _v(v: ParameterValue | None) -> str | None:
    return None if v is None else json.dumps(value_row(v))


class SqliteHistory:
    """History rows in SQLite: WAL, synchronous=FULL, one transaction per group."""

    def __init__(self, path: Path) -> None:
        self.db = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
        self.db.execute("pragma journal_mode=wal")
        self.db.execute("pragma synchronous=full")
        self.db.executescript(SCHEMA)

    def add(self, node: str, records: Sequence[HistoryRecord]) -> None:
        rows = [
            (node, r.seq, r.name, r.revision, r.time_ns, r.who, r.verified, r.via,
             _v(r.old), _v(r.new), r.applied, r.code, r.reason)
            for r in records
        ]  # fmt: skip
        self.db.execute("begin")
        self.db.executemany("insert into history values (?,?,?,?,?,?,?,?,?,?,?,?,?)", rows)
        self.db.execute("commit")

    def query(self, node: str, where: str, params: Sequence[object], *, pages: int = 10**9) -> int:
        """Rows of one query, page by page (500 rows, as a node answers), ``pages`` at most."""
        total, after = 0, 0
        for _ in range(pages):
            page = self.db.execute(
                f"select * from history where node = ? and seq > ? and {where} order by seq limit 500",
                (node, after, *params),
            ).fetchall()
            total += len(page)
            if len(page) < 500:
                break
            after = page[-1][1]
        return total

    def query_all(self, node: str, where: str, params: Sequence[object]) -> int:
        """Rows of one query in one pass."""
        sql = f"select * from history where node = ? and {where} order by seq"
        return len(self.db.execute(sql, (node, *params)).fetchall())

    def load_all(self) -> int:
        return sum(1 for _ in self.db.execute("select * from history order by node, seq"))

    def last_changes(self) -> int:
        sql = "select node, name, max(seq) from history where applied group by node, name"
        return len(self.db.execute(sql).fetchall())

    def close(self) -> None:
        self.db.close()


# -- change sets and their records ------------------------------------------------------------


def _groups(count: int, size: int) -> Iterator[tuple[ParameterTable, list[ChangeSet], list[HistoryRecord]]]:
    """``count`` changes of one node in groups of ``size``: its table, change sets and records."""
    table = ParameterTable(NODE)
    for i in range(50):
        table.declare(f"p{i:02d}", 0)
    history = NodeHistory(NODE, Retention(max_records=count + 1))
    changes: list[ChangeSet] = []
    table.add_change_listener(changes.append)
    n = 0
    while n < count:
        changes.clear()
        for _ in range(min(size, count - n)):
            with acting(Origin(AUTHORS[n % len(AUTHORS)], Via.API)):
                table.set([Parameter(f"p{n % 50:02d}", ParameterValue.from_python(n))])
            n += 1
        records = [r for c in changes for r in history.applied(c)]
        yield table, list(changes), records


def _cost(directory: Path, count: int, size: int) -> dict[str, list[float]]:
    """µs per change of each system, per persist call (one group), in fresh files."""
    groups = list(_groups(count, size))
    table = groups[0][0]
    directory = Path(tempfile.mkdtemp(prefix="cost-", dir=directory))
    stores = {name: persist_store(str(directory / f"{name}.yaml")) for name in ("state", "journal", "sqlite")}
    for store in stores.values():
        store.attach({NODE: table})
    sqlite = SqliteHistory(directory / "history.sqlite")
    cursors = dict.fromkeys(stores, 0)

    def call(name: str) -> Callable[[], None]:
        store = stores[name]

        def one() -> None:
            _, changes, records = groups[cursors[name] % len(groups)]
            cursors[name] += 1
            if name == "journal":
                store.record(table, changes, records)
            else:
                store.record(table, changes)
                if name == "sqlite":
                    sqlite.add(NODE, records)

        return one

    samples = alternate({name: (call(name), len(groups)) for name in stores}, len(groups))  # call by call
    for store in stores.values():
        store.close()
    sqlite.close()
    return {name: [s / size for s in values] for name, values in samples.items()}


# -- a million records -----------------------------------------------------------------------


def _records(nodes: int, per_node: int, t0: int) -> Iterator[HistoryRecord]:
    rnd = random.Random(7)
    for n in range(nodes):
        node = f"node{n:03d}"
        for seq in range(1, per_node + 1):
            old = ParameterValue.from_python(seq - 1)
            yield HistoryRecord(
                seq, node, f"p{rnd.randrange(50):02d}", seq, t0 + seq * 1_000_000, AUTHORS[rnd.randrange(20)],
                False, "api", old, ParameterValue.from_python(seq), True,
            )  # fmt: skip


def _timed(fn: Callable[[], object]) -> tuple[float, object]:
    t = time.perf_counter()
    out = fn()
    return (time.perf_counter() - t) * 1e3, out


def _queries(directory: Path, nodes: int, per_node: int) -> dict[str, float]:
    """ms of each query and reopen, journal store vs SQLite, at nodes x per_node records."""
    t0 = time.time_ns() - per_node * 1_000_000
    keep = Retention(max_records=per_node, max_age_s=1e9)
    tag = f"{nodes}x{per_node}"
    directory = Path(tempfile.mkdtemp(prefix="q-", dir=directory))
    hf = HistoryFile(directory / f"q-{tag}.yaml.history", keep)
    hf.load({})
    sqlite = SqliteHistory(directory / f"q-{tag}.sqlite")
    batch: list[HistoryRecord] = []
    for r in _records(nodes, per_node, t0):
        if batch and (len(batch) == 10_000 or batch[-1].node != r.node):
            hf.add(batch[-1].node, batch)
            sqlite.add(batch[-1].node, batch)
            batch = []
        batch.append(r)
    if batch:
        hf.add(batch[-1].node, batch)
        sqlite.add(batch[-1].node, batch)
    hf.rewrite()
    sqlite.close()
    del hf
    out: dict[str, float] = {}
    out["reopen_journal_ms"], loaded = _timed(
        lambda: _reopen_journal(directory / f"q-{tag}.yaml.history", keep)
    )
    histories: dict[str, NodeHistory] = loaded  # type: ignore[assignment]
    db = SqliteHistory(directory / f"q-{tag}.sqlite")
    out["reopen_sqlite_ms"], _ = _timed(db.load_all)
    db.close()
    db = SqliteHistory(directory / f"q-{tag}.sqlite")
    out["open_sqlite_last_ms"], _ = _timed(db.last_changes)
    node = "node000"
    lo, hi = t0 + per_node * 1_000_000 // 2, t0 + per_node * 1_000_000 // 2 + per_node * 10_000
    queries: dict[str, tuple[HistoryQuery, str, tuple[object, ...]]] = {
        "name": (HistoryQuery(names=("p07",)), "name = ?", ("p07",)),
        "time": (HistoryQuery(since_time_ns=lo, until_time_ns=hi), "time_ns between ? and ?", (lo, hi)),
        "who": (HistoryQuery(who="user7@*"), "who glob ?", ("user7@*",)),
    }
    mem = histories[node]
    for key, (q, where, params) in queries.items():
        # the first page (what one request returns), then every matching row in one pass
        ms, n1 = _timed(lambda q=q: len(mem.query(q).records))  # type: ignore[misc]
        out[f"q_{key}_page_journal_ms"] = ms
        ms, n2 = _timed(lambda w=where, p=params: db.query(node, w, p, pages=1))  # type: ignore[misc]
        out[f"q_{key}_page_sqlite_ms"] = ms
        assert n1 == n2, (key, n1, n2)
        everything = replace(q, limit=10**9)
        out[f"q_{key}_all_journal_ms"], n1 = _timed(lambda q=everything: len(mem.query(q).records))  # type: ignore[misc]
        out[f"q_{key}_all_sqlite_ms"], n2 = _timed(lambda w=where, p=params: db.query_all(node, w, p))  # type: ignore[misc]
        assert n1 == n2, (key, n1, n2)
        out[f"q_{key}_rows"] = float(n1)  # type: ignore[arg-type]
        if per_node <= 10_000:  # page after page: a node's query restarts its scan at each page
            out[f"q_{key}_pages_journal_ms"], _ = _timed(lambda q=q: _all_pages(mem, q))  # type: ignore[misc]
            out[f"q_{key}_pages_sqlite_ms"], _ = _timed(lambda w=where, p=params: db.query(node, w, p))  # type: ignore[misc]
    db.close()
    out["history_file_mb"] = os.path.getsize(directory / f"q-{tag}.yaml.history") / 1e6
    out["sqlite_mb"] = os.path.getsize(directory / f"q-{tag}.sqlite") / 1e6
    return out


def _reopen_journal(path: Path, keep: Retention) -> dict[str, NodeHistory]:
    hf = HistoryFile(path, keep)
    hf.load({})
    out = {}
    for node in hf.nodes():
        out[node] = NodeHistory(node, keep)
        hf.stored(node).restore_into(out[node])
    return out


def _all_pages(history: NodeHistory, q: HistoryQuery) -> int:
    total, after = 0, 0
    while True:
        page = history.query(
            HistoryQuery(q.names, q.since_revision, q.since_time_ns, q.until_time_ns, q.who, q.outcome, after)
        )
        total += len(page.records)
        if not page.more:
            return total
        after = page.records[-1].seq


# -- kill -9 ------------------------------------------------------------------------------------


def _store(path: Path) -> PersistStore:
    """``--persist``'s store, keeping every record the test writes."""

    def dump(state: Mapping[str, Snapshot]) -> str:
        return dump_text(state, with_descriptors=True)

    return PersistStore(path, dumper=dump, parser=parse_ros_text, retention=Retention(10**9, 1e9))


def writer(kind: str, path: str) -> None:
    """The child of the kill -9 test: write changes one by one, print each acknowledged seq."""
    store = _store(Path(path))
    sqlite = SqliteHistory(Path(f"{path}.sqlite")) if kind == "sqlite" else None
    table = ParameterTable(NODE)
    table.declare("p00", 0)
    store.compact_every = 500  # compactions happen during the run too
    store.attach({NODE: table})
    for table_, changes, records in _groups(10**9, 1):
        if sqlite is None:
            store.record(table_, changes, records)
        else:
            store.record(table_, changes)
            sqlite.add(NODE, records)
        os.write(1, b"%d\n" % records[-1].seq)


def _kill9(directory: Path, kind: str, rounds: int) -> list[tuple[int, bool, float]]:
    """(acknowledged, all there and readable, reopen ms) per round."""
    out = []
    for r in range(rounds):
        path = directory / f"kill-{kind}-{r}.yaml"
        code = f"from paramdds.bench.history_store import writer; writer({kind!r}, {str(path)!r})"
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE)
        assert proc.stdout is not None
        acked = 0
        deadline = time.monotonic() + 0.2 + 0.8 * random.random()
        for line in proc.stdout:
            acked = int(line)
            if time.monotonic() > deadline:
                break
        os.kill(proc.pid, signal.SIGKILL)
        for line in proc.stdout:  # what was printed before the kill was acknowledged too
            acked = int(line)
        proc.wait()
        ok = True
        t = time.perf_counter()
        try:
            if kind == "sqlite":
                db = sqlite3.connect(f"{path}.sqlite")
                ok = db.execute("pragma integrity_check").fetchone()[0] == "ok"
                seqs = [
                    s for (s,) in db.execute("select seq from history where node = ? order by seq", (NODE,))
                ]
                db.close()
            else:
                store = _store(path)
                store.read(NODE)
                seqs = [rec.seq for rec in store.history(NODE).records]
        except Exception as exc:  # a damaged store: the failure this measures
            note(f"history-store: {kind} did not reopen: {exc}")
            ok, seqs = False, []
        ms = (time.perf_counter() - t) * 1e3
        ok = ok and seqs[:acked] == list(range(1, acked + 1)) if acked else ok
        out.append((acked, ok, ms))
    return out


def _range(values: Sequence[float], digits: int = 1) -> str:
    lo, hi = min(values), max(values)
    return (
        f"{lo:.{digits}f}" if round(lo, digits) == round(hi, digits) else f"{lo:.{digits}f}-{hi:.{digits}f}"
    )


def _row(label: str, runs: Sequence[dict[str, float]], journal: str, digits: int) -> tuple[object, ...]:
    sqlite = journal.replace("_journal_", "_sqlite_")
    return (label, _range([r[journal] for r in runs], digits), _range([r[sqlite] for r in runs], digits), "")


def run(args: argparse.Namespace) -> int:
    rounds = args.rounds or (2 if args.quick else 3)
    count = args.requests or (300 if args.quick else 2000)
    total = args.records or (20_000 if args.quick else 1_000_000)
    data: dict[str, Any] = {"rounds": rounds, "changes": count, "records": total}
    rows: list[tuple[object, ...]] = []
    with tempfile.TemporaryDirectory(prefix="paramdds-bench-history-") as tmp:
        directory = Path(tmp)
        for size in (1, 8):
            note(f"history-store: cost per change, groups of {size}")
            per_round: dict[str, list[float]] = {"state": [], "journal": [], "sqlite": []}
            for _ in range(rounds):
                for name, samples in _cost(directory, count, size).items():
                    per_round[name].append(median(samples))
            for name, meds in per_round.items():
                data[f"us_per_change_g{size}_{name}"] = [round(m, 1) for m in meds]
            rows.append((f"µs per change, groups of {size}", _range(per_round["journal"], 0),
                         _range(per_round["sqlite"], 0), _range(per_round["state"], 0)))  # fmt: skip
        for nodes in (100, 1):
            per_node = total // nodes
            note(f"history-store: {nodes} x {per_node:,} records")
            runs = [_queries(directory, nodes, per_node) for _ in range(max(1, rounds - 1))]
            data[f"queries_{nodes}x{per_node}"] = runs
            label = f"{nodes} node{'s' if nodes > 1 else ''} x {per_node:,}"
            for key, text in (
                ("q_name", "by node+name"),
                ("q_time", "by time range"),
                ("q_who", "by who glob"),
            ):
                n = int(runs[0][f"{key}_rows"])
                rows.append(_row(f"ms, {text}, first page, {label}", runs, f"{key}_page_journal_ms", 1))
                rows.append(_row(f"ms, {text}, {n:,} rows in one pass", runs, f"{key}_all_journal_ms", 1))
                if f"{key}_pages_journal_ms" in runs[0]:
                    label_pages = f"ms, {text}, {n:,} rows page by page"
                    rows.append(_row(label_pages, runs, f"{key}_pages_journal_ms", 1))
            rows.append(_row(f"ms, reopen: read every record, {label}", runs, "reopen_journal_ms", 0))
            rows.append((f"ms, SQLite open + last changes only, {label}", "",
                         _range([r["open_sqlite_last_ms"] for r in runs], 0), ""))  # fmt: skip
            rows.append((f"MB on disk, {label}", _range([r["history_file_mb"] for r in runs]),
                         _range([r["sqlite_mb"] for r in runs]), ""))  # fmt: skip
        for kind in ("journal", "sqlite"):
            note(f"history-store: kill -9 of a {kind} writer, {rounds + 2} times")
            results = _kill9(directory, kind, rounds + 2)
            data[f"kill9_{kind}"] = [
                {"acknowledged": a, "intact": ok, "reopen_ms": round(ms, 1)} for a, ok, ms in results
            ]
            data[f"kill9_{kind}_intact"] = all(ok for _, ok, _ in results)
        rows.append(
            (
                "kill -9: every acknowledged record there, files intact",
                "yes" if data["kill9_journal_intact"] else "NO",
                "yes" if data["kill9_sqlite_intact"] else "NO",
                "",
            )
        )
        rows.append(("kill -9: ms to reopen", _range([r["reopen_ms"] for r in data["kill9_journal"]]),
                     _range([r["reopen_ms"] for r in data["kill9_sqlite"]]), ""))  # fmt: skip
    table = render(["measure", "journal", "SQLite WAL", "state alone"], rows)
    table += (
        f"\n\nranges over the rounds (cost: {rounds} rounds, the median per round of {count:,} changes "
        "taking turns call by call; queries: the journal's run on the nodes' memory after the reopen, "
        "as a server answers them)"
    )
    emit(args, data, table)
    return 0
