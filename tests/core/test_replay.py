"""The seam of watch --since: history and live changes, in any interleaving, give each change once."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.replay import Gap, Seam

Change = tuple[int, str]
Run = tuple[list[set[str]], int, list[bool], list[int], int]


@st.composite
def runs(draw: st.DrawFn) -> Run:
    """Commits (revision i+1 changes the names commits[i]), the revision watched from, which
    live samples arrive, the order of steps (0 a commit, 1 a live sample, 2 a history read
    on the watcher's own), and the revisions retention dropped (history holds those above)."""
    made = draw(st.lists(st.sets(st.sampled_from("abcd"), min_size=1), min_size=1, max_size=12))
    changes = sum(len(c) for c in made)
    since = draw(st.integers(0, len(made)))
    arrives = draw(st.lists(st.booleans(), min_size=changes, max_size=changes))
    steps = draw(st.lists(st.integers(0, 2), max_size=3 * changes + 4))
    dropped = draw(st.integers(0, len(made)))
    return made, since, arrives, steps, dropped


def _play(run: Run, *, dropped: int) -> list[Change | Gap]:
    made, since, arrives, steps, _ = run
    log = [(rev, name) for rev, names in enumerate(made, 1) for name in sorted(names)]
    live = [c for c, ok in zip(log, arrives, strict=True) if ok]
    seam: Seam[Change] = Seam(since)
    out: list[Change | Gap] = []
    committed = 0  # revisions made so far
    sent = 0  # live samples delivered so far

    def history() -> None:
        after = seam.top
        out.extend(seam.history([(r, (r, n)) for r, n in log if after < r <= committed and r > dropped]))
        if seam.wanted:
            out.extend(seam.skip())  # history does not reach what was seen live: reported

    history()  # the replay
    for step in [*steps, *[0] * len(made), *[1] * len(live)]:
        if step == 0 and committed < len(made):
            committed += 1
        elif step == 1 and sent < len(live) and live[sent][0] <= committed:
            rev, _ = live[sent]
            sent += 1
            if seam.live(rev):
                history()
        elif step == 2:
            history()
    return out


def _changes(out: list[Change | Gap]) -> list[Change]:
    return [x for x in out if not isinstance(x, Gap)]


def _expected(made: list[set[str]], after: int) -> list[Change]:
    return [(rev, name) for rev, names in enumerate(made, 1) if rev > after for name in sorted(names)]


@settings(max_examples=400)
@given(runs())
def test_each_change_once_in_revision_order(run: Run) -> None:
    made, since, arrives, _, _ = run
    out = _play(run, dropped=0)
    assert not [x for x in out if isinstance(x, Gap)]
    changes = _changes(out)
    assert len(changes) == len(set(changes))  # once
    assert [r for r, _ in changes] == sorted(r for r, _ in changes)  # never back
    if arrives and arrives[-1]:  # the last change was seen live: everything up to it came
        assert changes == _expected(made, since)
    else:
        assert set(changes) <= set(_expected(made, since))


@settings(max_examples=400)
@given(runs())
def test_what_history_lacks_is_a_gap_never_a_silent_skip(run: Run) -> None:
    made, since, arrives, _, dropped = run
    out = _play(run, dropped=dropped)
    changes = _changes(out)
    assert len(changes) == len(set(changes))
    marks = [x.before if isinstance(x, Gap) else x[0] for x in out]
    assert marks == sorted(marks)
    lost = {r for g in out if isinstance(g, Gap) for r in range(g.after + 1, g.before)}
    delivered = {r for r, _ in changes} | lost
    last_seen = max((r for (r, _), ok in zip(_expected(made, 0), arrives, strict=True) if ok), default=0)
    assert set(range(since + 1, last_seen + 1)) <= delivered  # up to what was seen live: none missed silently
    for rev in {r for r, _ in changes}:  # a revision delivered is delivered whole
        assert {n for r, n in changes if r == rev} == made[rev - 1]


def test_a_revision_seen_live_is_read_from_history() -> None:
    seam: Seam[str] = Seam(3)
    assert seam.live(2) is False  # a parameter's state, older than the revision watched from
    assert seam.live(5) is True
    assert seam.history([(4, "a4"), (5, "a5"), (5, "b5")]) == ["a4", "a5", "b5"]
    assert not seam.wanted
    assert seam.live(5) is False
    assert seam.history([(5, "again")]) == []


def test_a_revision_history_dropped_is_a_gap() -> None:
    seam: Seam[str] = Seam(1)
    assert seam.history([(4, "a4"), (5, "a5")]) == [Gap(1, 4), "a4", "a5"]


def test_skip_reports_what_history_never_reaches() -> None:
    seam: Seam[str] = Seam(1)
    seam.live(5)
    assert seam.history([(2, "a2")]) == ["a2"]
    assert seam.skip() == [Gap(2, 6)]
    assert seam.top == 5
    assert seam.history([(6, "a6")]) == ["a6"]


def test_reset_starts_a_new_incarnation() -> None:
    seam: Seam[str] = Seam(9)
    seam.reset()
    assert seam.live(1) is True
    assert seam.history([(1, "a1")]) == ["a1"]
