"""NodeHistory: records in order, retention by count and age, compaction said, last changes; rewind."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.history import HistoryQuery, HistoryRecord, NodeHistory, Outcome, Retention, rewind
from paramdds.core.origin import Origin, Via, acting
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterValue

ALICE = Origin("alice", Via.CLI)


def _fed(retention: Retention | None = None) -> tuple[ParameterTable, NodeHistory]:
    table = ParameterTable("n", allow_undeclared=True)
    history = NodeHistory("n", retention)
    table.add_change_listener(history.applied)
    return table, history


def test_a_change_is_recorded_with_its_origin_old_and_new_values() -> None:
    table, history = _fed()
    with acting(ALICE):
        table.set_atomically([])  # nothing committed, nothing recorded
        table.set([_p("a", 1)])
        table.set([_p("a", 2), _p("b", "x")])
    table.set([_p("a", ParameterValue.from_python(None))])  # a delete, by the process itself
    page = history.query(HistoryQuery())
    rows = [(r.name, r.revision, r.who, r.via, _py(r.old), _py(r.new)) for r in page.records]
    assert rows[:3] == [
        ("a", 1, "alice", "cli", None, 1),
        ("a", 2, "alice", "cli", 1, 2),
        ("b", 2, "alice", "cli", None, "x"),
    ]
    assert rows[3][:2] == ("a", 3) and rows[3][3:] == ("api", 2, None) and page.records[3].verified
    assert history.last("a") is None and history.last("b") is not None and history.last("b").revision == 2
    assert not page.more and not page.compacted


def test_refusals_are_recorded_apart_from_changes() -> None:
    table, history = _fed()
    table.set([_p("a", 1)])
    history.refused(ALICE, table.revision, [("a", _v(1), _v(9), "OUT_OF_RANGE", "too big")])
    refused = history.query(HistoryQuery(outcome=Outcome.REFUSED)).records
    assert [(r.name, r.applied, r.code, _py(r.new)) for r in refused] == [("a", False, "OUT_OF_RANGE", 9)]
    assert len(history.query(HistoryQuery(outcome=Outcome.APPLIED)).records) == 1
    last = history.last("a")
    assert last is not None and last.who != "alice"  # a refusal changes no blame


@given(st.integers(1, 40), st.integers(1, 120), st.integers(1, 17))
def test_retention_keeps_the_newest_and_says_what_it_dropped(keep: int, changes: int, page: int) -> None:
    table, history = _fed(Retention(max_records=keep))
    for i in range(changes):
        table.set([_p("x", i)])
    everything: list[int] = []
    q = HistoryQuery(limit=page)
    assert history.query(q).compacted == (changes > keep)
    while True:  # paging returns every retained record once, in order
        got = history.query(q)
        everything += [r.seq for r in got.records]
        if not got.more:
            break
        q = HistoryQuery(limit=page, after_seq=got.records[-1].seq)
    assert everything == list(range(max(1, changes - keep + 1), changes + 1))
    newest = history.query(HistoryQuery(since_revision=changes - min(keep, changes)))
    assert not newest.compacted  # a range inside what is kept is whole


def test_retention_by_age_drops_old_records() -> None:
    history = NodeHistory("n", Retention(max_age_s=60))
    old = 1_000_000_000_000
    history.refused(ALICE, 0, [("a", None, _v(1), "X", "")], time_ns=old)
    history.refused(ALICE, 0, [("a", None, _v(2), "X", "")], time_ns=old + 61 * 10**9)
    page = history.query(HistoryQuery())
    assert [_py(r.new) for r in page.records] == [2] and page.compacted
    assert not history.query(HistoryQuery(since_time_ns=old + 10**9)).compacted


@given(
    st.lists(st.tuples(st.sampled_from("abc"), st.one_of(st.none(), st.integers(0, 9))), max_size=30),
    st.data(),
)
def test_rewind_rebuilds_the_values_at_any_revision(
    steps: list[tuple[str, int | None]], data: st.DataObject
) -> None:
    table, history = _fed()
    then: dict[int, dict[str, ParameterValue]] = {0: {}}  # revision -> the values at it
    for name, value in steps:
        table.set([_p(name, value)])
        then[table.revision] = {n: v for n, v, _ in table.snapshot()}
    at = data.draw(st.sampled_from(sorted(then)))
    since = history.query(HistoryQuery(since_revision=at, limit=10_000)).records
    assert rewind(then[table.revision], since) == then[at]


def _p(name: str, value: object) -> Parameter:
    v = value if isinstance(value, ParameterValue) else ParameterValue.from_python(value)
    return Parameter(name, v)


def _v(x: object) -> ParameterValue:
    return ParameterValue.from_python(x)


def _py(v: ParameterValue | None) -> object:
    return None if v is None else v.value


@given(st.sets(st.integers(1, 200), max_size=60), st.integers(1, 9))
def test_paging_a_restored_history_with_gaps_returns_each_record_once(seqs: set[int], page: int) -> None:
    history = NodeHistory("n")
    now = 2_000_000_000_000_000_000
    kept = [history_record(seq, now) for seq in sorted(seqs)]
    history.restore(kept, {})
    got: list[int] = []
    q = HistoryQuery(limit=page)
    while True:
        answer = history.query(q)
        got += [r.seq for r in answer.records]
        if not answer.more:
            break
        q = HistoryQuery(limit=page, after_seq=answer.records[-1].seq)
    assert got == sorted(seqs)


def history_record(seq: int, time_ns: int) -> HistoryRecord:
    return HistoryRecord(seq, "n", "x", seq, time_ns, "w", False, "api", None, _v(seq))


def test_a_revision_counts_in_this_life_a_time_across_lives() -> None:
    """After a restart with --persist the revisions count from 1 again: --since REV means this
    life's revisions (the earlier life's records are all before them), --since TIME reaches both."""
    earlier_table, earlier = _fed(Retention(max_records=4))
    for i in range(6):  # revisions 1..6; retention keeps the newest 4 (3..6), dropped up to 2
        earlier_table.set([_p("x", i)])
    kept = earlier.query(HistoryQuery()).records
    table, history = _fed(Retention(max_records=100))
    history.restore(kept, earlier.last_changes(), dropped_seq=2, dropped_revision=2)
    table.set([_p("x", 10)])
    table.set([_p("x", 11)])  # this life's revisions 1 and 2
    since_1 = history.query(HistoryQuery(since_revision=1))
    assert [(r.revision, _py(r.new)) for r in since_1.records] == [(2, 11)]
    assert not since_1.compacted  # the drop was in the earlier life: nothing of this one is missing
    since_0 = history.query(HistoryQuery(since_revision=0, limit=1))  # paged, from this life on
    assert [_py(r.new) for r in since_0.records] == [10] and since_0.more
    everything = history.query(HistoryQuery(since_time_ns=0))
    assert [_py(r.new) for r in everything.records] == [2, 3, 4, 5, 10, 11] and everything.compacted
    assert rewind({"x": _v(11)}, since_1.records) == {"x": _v(10)}  # diff NODE@1 in this life
