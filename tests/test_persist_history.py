"""The history a --persist server keeps across restarts, without DDS: the store's writes,
reopening, compactions, retention and its watermark, torn and damaged files.

A node's :class:`NodeHistory` (fed the table's change sets and some refusals, as the
server feeds it) is the reference: what a reopened store hands back is what it held,
records with their seq, who, via, old and new, and every parameter's last change.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from unittest.mock import patch

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.history import HistoryQuery, HistoryRecord, NodeHistory, Retention
from paramdds.core.origin import Origin, Via, acting
from paramdds.core.results import ChangeSet
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterValue
from paramdds.formats.files import dump_text, parse_ros_text
from paramdds.persist import PersistError, PersistStore
from paramdds.persist import history as persist_history


def _store(path: Path, **kw: object) -> PersistStore:
    return PersistStore(
        path,
        dumper=lambda s: dump_text(s, with_descriptors=True),
        parser=parse_ros_text,
        **kw,  # type: ignore[arg-type]
    )


class _Node:
    """A table, its NodeHistory and a store, committed and persisted as a server's worker does."""

    def __init__(self, path: Path, retention: Retention | None = None, compact_every: int = 10_000) -> None:
        self.table = ParameterTable("n", allow_undeclared=True)
        self.table.declare("x", 0)
        self.history = NodeHistory("n", retention)
        self.changes: list[ChangeSet] = []
        self.table.add_change_listener(self.changes.append)
        self.store = _store(path, retention=retention, compact_every=compact_every)
        self.store.history("n").restore_into(self.history)
        self.store.attach({"n": self.table})

    def set(self, name: str, value: object, who: str = "ann", via: Via = Via.CLI) -> list[HistoryRecord]:
        self.changes.clear()
        with acting(Origin(who, via)):
            self.table.set([Parameter(name, ParameterValue.from_python(value))])
        records = [r for c in self.changes for r in self.history.applied(c)]
        self.store.record(self.table, list(self.changes), records)
        return records

    def delete(self, name: str, who: str = "ann") -> None:
        self.changes.clear()
        with acting(Origin(who, Via.API)):
            self.table.undeclare(name)
        records = [r for c in self.changes for r in self.history.applied(c)]
        self.store.record(self.table, list(self.changes), records)

    def refuse(self, name: str, value: object, who: str = "eve") -> None:
        asked = ParameterValue.from_python(value)
        now = self.table.get(name) if self.table.has(name) else None
        records = self.history.refused(
            Origin(who, Via.WEB), self.table.revision, [(name, now, asked, "READ_ONLY", "no")]
        )
        self.store.record(self.table, [], records)


def _reopened(path: Path, retention: Retention | None = None) -> NodeHistory:
    history = NodeHistory("n", retention)
    _store(path, retention=retention).history("n").restore_into(history)
    return history


def _all(h: NodeHistory) -> list[HistoryRecord]:
    out: list[HistoryRecord] = []
    while True:
        page = h.query(HistoryQuery(after_seq=out[-1].seq if out else 0))
        out += page.records
        if not page.more:
            return out


def test_applied_and_refused_records_and_blame_survive_a_reopen(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml")
    node.set("x", 1, who="ann")
    node.set("y", "a", who="bob", via=Via.LOAD)
    node.refuse("x", 9, who="eve")
    node.set("x", 2, who="bob")
    node.delete("y", who="ann")
    node.store.close()
    again = _reopened(tmp_path / "s.yaml")
    assert _all(again) == _all(node.history)
    got = [
        (r.name, r.who, r.via, r.old and r.old.value, r.new and r.new.value, r.applied) for r in _all(again)
    ]
    assert got == [
        ("x", "ann", "cli", 0, 1, True),
        ("y", "bob", "load", None, "a", True),
        ("x", "eve", "web", 2 - 1, 9, False),
        ("x", "bob", "cli", 1, 2, True),
        ("y", "ann", "api", "a", None, True),
    ]
    assert again.last_changes() == node.history.last_changes()
    assert set(again.last_changes()) == {"x"}  # y was deleted: no blame
    assert again.last("x").who == "bob"  # type: ignore[union-attr]
    assert again.next_seq == node.history.next_seq  # the count goes on


def test_records_survive_compactions_once_and_only_once(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml", compact_every=3)  # the journal is truncated every 3 lines
    for v in range(1, 11):
        node.set("x", v, who=f"u{v}")
    assert Path(f"{tmp_path / 's.yaml'}.history").exists()
    node.store.close()
    again = _reopened(tmp_path / "s.yaml")
    assert [r.seq for r in _all(again)] == list(range(1, 11))
    assert [r.who for r in _all(again)] == [f"u{v}" for v in range(1, 11)]


def test_a_crash_between_a_checkpoint_and_the_journal_truncation_duplicates_nothing(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml")
    for v in range(1, 5):
        node.set("x", v)
    node.store.history_file.checkpoint()  # the records reach FILE.history; the journal still holds them
    node.store.close()
    again = _reopened(tmp_path / "s.yaml")
    assert [r.seq for r in _all(again)] == [1, 2, 3, 4]
    assert [r.new.value for r in _all(again)] == [1, 2, 3, 4]  # type: ignore[union-attr]


def test_retention_drops_the_oldest_keeps_every_blame_and_remembers_the_watermark(tmp_path: Path) -> None:
    keep = Retention(max_records=3)
    node = _Node(tmp_path / "s.yaml", retention=keep, compact_every=2)
    node.set("y", "only once", who="old")  # seq 1: dropped below, its blame stays
    for v in range(1, 7):
        node.set("x", v)
    node.store.write()  # a compaction: the file is rewritten when it is long enough (not yet: slack)
    node.store.close()
    again = _reopened(tmp_path / "s.yaml", keep)
    assert [r.seq for r in _all(again)] == [5, 6, 7]
    assert again.last("y") is not None and again.last("y").who == "old"  # type: ignore[union-attr]
    assert again.query(HistoryQuery()).compacted  # the whole range reaches past what is kept
    assert not again.query(HistoryQuery(after_seq=4)).compacted


def test_a_rewrite_keeps_only_what_retention_keeps(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import paramdds.persist.history as ph

    monkeypatch.setattr(ph, "REWRITE_SLACK", 0)
    keep = Retention(max_records=4)
    node = _Node(tmp_path / "s.yaml", retention=keep, compact_every=3)
    node.set("y", 1, who="first")
    for v in range(1, 30):
        node.set("x", v)
    node.store.write()
    lines = Path(f"{tmp_path / 's.yaml'}.history").read_bytes().count(b'["r"')
    assert lines <= 2 * 4  # rewritten: not the 30 records set
    node.store.close()
    again = _reopened(tmp_path / "s.yaml", keep)
    assert [r.seq for r in _all(again)] == [27, 28, 29, 30]
    assert again.last("y").who == "first"  # type: ignore[union-attr]
    assert again.query(HistoryQuery()).compacted


def test_retention_by_age_applies_on_reopen(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml")
    node.set("x", 1)
    node.set("x", 2)
    node.store.close()
    again = _reopened(tmp_path / "s.yaml", Retention(max_age_s=1e-9))  # everything is older than that
    assert _all(again) == []
    assert again.last("x").who == "ann"  # type: ignore[union-attr]
    assert again.next_seq == 3


def test_a_torn_last_history_line_is_dropped_and_the_file_rewritten(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml", compact_every=2)
    for v in range(1, 6):
        node.set("x", v)
    node.store.close()
    path = Path(f"{tmp_path / 's.yaml'}.history")
    path.write_bytes(path.read_bytes() + b'0badc0de ["r","n",9')  # a crash during an append
    again = _Node(tmp_path / "s.yaml")  # reopens, attaches: the file is rewritten whole
    assert [r.seq for r in _all(again.history)] == [1, 2, 3, 4, 5]
    assert not path.read_bytes().endswith(b"9")
    again.store.close()


def test_a_damaged_history_line_before_the_last_refuses_the_start(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml", compact_every=1)
    for v in range(1, 6):
        node.set("x", v)
    node.store.close()
    path = Path(f"{tmp_path / 's.yaml'}.history")
    raw = path.read_bytes()
    second = raw.index(b"\n", raw.index(b"\n") + 1) + 5
    path.write_bytes(raw[:second] + b"X" + raw[second + 1 :])
    with pytest.raises(PersistError, match="damaged"):
        _store(tmp_path / "s.yaml").history("n")


def test_a_file_that_is_not_a_history_file_refuses_the_start(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml")
    node.store.close()
    Path(f"{tmp_path / 's.yaml'}.history").write_text("x: 1\n")
    with pytest.raises(PersistError, match="not a paramdds history file"):
        _store(tmp_path / "s.yaml").history("n")


_OPS = st.lists(
    st.one_of(
        st.tuples(st.just("set"), st.sampled_from("xyz"), st.integers(0, 9), st.sampled_from(["ann", "bob"])),
        st.tuples(st.just("delete"), st.sampled_from("yz"), st.just(0), st.just("ann")),
        st.tuples(st.just("refuse"), st.sampled_from("xyz"), st.integers(0, 9), st.just("eve")),
        st.tuples(st.just("restart"), st.just(""), st.just(0), st.just("")),
    ),
    max_size=40,
)


@settings(max_examples=100, deadline=None)
@given(_OPS, st.integers(1, 5), st.integers(2, 12), st.sampled_from([0, 3, 10_000]))
@example(  # y's only record is dropped, the file rewritten: its blame must survive the restart
    [("set", "y", 1, "ann"), *[("set", "x", v, "bob") for v in range(6)], ("restart", "", 0, "")], 1, 2, 0
)
def test_whatever_happens_a_reopened_store_holds_what_the_node_held(
    tmp_path_factory: pytest.TempPathFactory,
    ops: list[tuple[str, str, int, str]],
    every: int,
    keep: int,
    slack: int,
) -> None:
    with patch.object(persist_history, "REWRITE_SLACK", slack):  # 0: rewritten at every compaction
        _run_ops(tmp_path_factory.mktemp("h") / "s.yaml", ops, every, keep)


def _run_ops(path: Path, ops: list[tuple[str, str, int, str]], every: int, keep: int) -> None:
    retention = Retention(max_records=keep)
    node = _Node(path, retention, compact_every=every)
    for op, name, value, who in ops:
        if op == "set":
            node.set(name, value, who=who)
        elif op == "delete" and node.table.has(name):
            node.delete(name, who=who)
        elif op == "refuse":
            node.refuse(name, value, who=who)
        elif op == "restart":
            node.store.close()
            before = _all(node.history), node.history.last_changes(), node.history.next_seq
            node = _Node(path, retention, compact_every=every)
            assert (_all(node.history), node.history.last_changes(), node.history.next_seq) == before
    node.store.close()
    again = _reopened(path, retention)
    assert _all(again) == _all(node.history)
    assert again.last_changes() == node.history.last_changes()
    assert again.next_seq == node.history.next_seq


def test_a_crash_between_the_snapshot_and_the_journal_restart_loses_no_record(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import paramdds.persist as persist

    node = _Node(tmp_path / "s.yaml")
    for v in range(1, 4):
        node.set("x", v)

    def crash(self: object, epoch: str) -> None:
        raise KeyboardInterrupt("killed")  # the snapshot has its new epoch; the journal keeps the old

    monkeypatch.setattr(persist._Journal, "restart", crash)
    with pytest.raises(KeyboardInterrupt):
        node.store.write()
    monkeypatch.undo()
    node.store.close()
    again = _reopened(tmp_path / "s.yaml")  # the journal is ignored (not the snapshot's epoch)
    assert [r.new.value for r in _all(again)] == [1, 2, 3]  # type: ignore[union-attr]
    assert again.last("x").who == "ann"  # type: ignore[union-attr]


def test_a_torn_journal_line_drops_the_changes_and_their_records_together(tmp_path: Path) -> None:
    node = _Node(tmp_path / "s.yaml")
    node.set("x", 1)
    node.set("x", 2)
    node.store.close()
    journal = Path(f"{tmp_path / 's.yaml'}.journal")
    raw = journal.read_bytes().split(b"\0", 1)[0]
    journal.write_bytes(raw[:-10])  # the last append cut by a crash (never acknowledged)
    store = _store(tmp_path / "s.yaml")
    assert {name: value.value for name, value, _ in store.read("n")} == {"x": 1}
    assert [r.new.value for r in store.history("n").records] == [1]  # type: ignore[union-attr]


def _wired(path: Path) -> tuple[ParameterTable, NodeHistory, PersistStore, list[ChangeSet]]:
    """A table whose history tells the store its records, as a server wires them; the
    change sets committed go to the list returned (what the worker's persist call takes)."""
    table = ParameterTable("n")
    table.declare("x", 0)
    history = NodeHistory("n")
    store = _store(path)
    store.attach({"n": table})
    history.add_listener(partial(store.recorded, "n"))
    changes: list[ChangeSet] = []
    table.add_change_listener(changes.append)
    table.add_change_listener(history.applied)  # type: ignore[arg-type]  # as the node's worker does
    return table, history, store, changes


def test_records_told_to_the_store_wait_for_their_changes_and_a_refusal_alone_is_written_at_once(
    tmp_path: Path,
) -> None:
    table, history, store, changes = _wired(tmp_path / "s.yaml")
    with acting(Origin("ann", Via.CLI)):
        table.set([Parameter("x", ParameterValue.from_python(1))])
    assert _store(tmp_path / "s.yaml").history("n").records == ()  # waiting for its change's line
    store.record(table, changes)  # the worker's persist call: the change and its record, one line
    assert [r.who for r in _store(tmp_path / "s.yaml").history("n").records] == ["ann"]
    history.refused(Origin("eve", Via.WEB), table.revision, [("x", None, None, "READ_ONLY", "no")])
    got = _store(tmp_path / "s.yaml").history("n").records  # no persist call needed
    assert [(r.who, r.applied) for r in got] == [("ann", True), ("eve", False)]
    history.started([("y", ParameterValue.from_python(2))], table.revision, Origin("me", Via.START), 1)
    store.write_history()
    assert _store(tmp_path / "s.yaml").history("n").records[-1].via == "start"
    store.close()


def test_a_compaction_takes_the_records_of_the_changes_its_snapshot_holds(tmp_path: Path) -> None:
    """A compaction run by another node's append snapshots every table; a change committed
    there whose record still waits for its own node's append is in that snapshot. Killed
    before that append, the restarted server must hold the change and its record, or
    neither (a retry then finds the value set, changes nothing and records nothing)."""
    table, _, store, _ = _wired(tmp_path / "s.yaml")
    with acting(Origin("ann", Via.CLI)):
        table.set([Parameter("x", ParameterValue.from_python(1))])
    store.write()  # another node's append reached the compaction threshold
    # killed here: the node's own append never ran
    reopened = _store(tmp_path / "s.yaml")
    assert {name: value.value for name, value, _ in reopened.read("n")} == {"x": 1}
    assert [(r.who, r.new and r.new.value) for r in reopened.history("n").records] == [("ann", 1)]
    store.close()


def test_a_compaction_keeps_the_deletions_its_snapshot_holds(tmp_path: Path) -> None:
    """The same for a deletion: a snapshot without the name keeps its deletion record, or a
    restart brings the name back from the parameter files while its history says deleted; a
    name deleted, then declared again before the compaction, stays."""
    table, _, store, _ = _wired(tmp_path / "s.yaml")
    for name in ("y", "z"):
        table.declare(name, 2, ParameterDescriptor("", dynamic_typing=True))
    store.write()
    with acting(Origin("ann", Via.CLI)):
        table.undeclare("y")
        table.undeclare("z")
        table.declare("z", 3, ParameterDescriptor("", dynamic_typing=True))
    store.write()  # another node's append compacts; killed before this node's own append
    reopened = _store(tmp_path / "s.yaml")
    assert reopened.deleted("n") == ["y"]
    assert {name: value.value for name, value, _ in reopened.read("n")} == {"x": 0, "z": 3}
    deletions = [r.name for r in reopened.history("n").records if r.applied and r.new is None]
    assert deletions == ["y", "z"]
    store.close()


def test_a_name_deleted_and_declared_again_is_not_deleted_in_a_compaction_between(tmp_path: Path) -> None:
    """The deletion's append ran (it takes every record waiting, the re-declaration's too),
    the re-declaration's not yet, when another node's append compacts: the snapshot holds the
    name, so no deletion record may say it is gone (a restart leaves a deleted name out
    whatever the snapshot and the files hold)."""
    table, _, store, changes = _wired(tmp_path / "s.yaml")
    table.declare("y", 2, ParameterDescriptor("", dynamic_typing=True))
    table.undeclare("y")
    table.declare("y", 3, ParameterDescriptor("", dynamic_typing=True))
    # the deletion's append, which takes every record waiting (the re-declaration's too)
    store.record(table, changes[-2:-1])
    store.write()  # another node's append compacts; killed before the re-declaration's append
    reopened = _store(tmp_path / "s.yaml")
    assert reopened.deleted("n") == []
    assert {name: value.value for name, value, _ in reopened.read("n")} == {"x": 0, "y": 3}
    store.close()
