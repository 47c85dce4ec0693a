"""What history and diff print, and diff between files: no DDS."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from paramdds.cli import main
from paramdds.cli.verbs.diff import Block, blocks_text, difference_line
from paramdds.cli.verbs.history import compacted_line, history_line
from paramdds.core.diff import compare
from paramdds.core.history import HistoryRecord
from paramdds.core.values import ParameterValue

T0 = 1_795_917_162_610_430_000  # 2026-11-29T01:52:42.610Z


def record(**kw: object) -> HistoryRecord:
    base: dict[str, object] = dict(
        seq=1, node="robot1", name="robot.max_velocity", revision=3, time_ns=T0, who="alice",
        verified=False, via="cli", old=ParameterValue.from_python(1.5), new=ParameterValue.from_python(2.5),
    )  # fmt: skip
    return HistoryRecord(**{**base, **kw})  # type: ignore[arg-type]


def test_a_history_line_marks_a_claim_and_a_refusal() -> None:
    assert history_line(record()) == (
        "2026-11-29T01:52:42.610Z  rev 3  robot.max_velocity: 1.5 → 2.5  by alice (claimed) via cli"
    )
    assert history_line(record(verified=True, old=None, via="start")).endswith(
        "robot.max_velocity: (none) → 2.5  by alice via start"
    )
    refused = history_line(record(applied=False, code="OUT_OF_RANGE", reason="must be within [0.0, 5.0]"))
    assert refused.endswith("via cli  REFUSED: must be within [0.0, 5.0]")
    assert history_line(record(new=None)).split("  ")[2] == "robot.max_velocity: 1.5 → (deleted)"


def test_the_compacted_line_names_the_oldest_kept() -> None:
    assert compacted_line("robot1", [record()]) == (
        "retention dropped part of the history of node 'robot1' asked for: "
        "the oldest record kept is at revision 3 (2026-11-29T01:52:42.610Z)"
    )
    assert "none of it is kept" in compacted_line("robot1", [])


def test_difference_lines() -> None:
    v = ParameterValue.from_python
    diffs = compare({"a": v(1), "b": v("x")}, {"a": v(2), "c": v([1.0])})
    assert [difference_line(d, "robot1", "f.yaml") for d in diffs] == [
        "a: 1 → 2",
        "b: only in robot1 ('x')",
        "c: only in f.yaml ([1.0])",
    ]
    blocks = [Block("r1", "r1", "f", diffs[:1]), Block("r2", "r2", "f", [])]
    assert blocks_text(blocks, by_node=True) == "r1:\n  a: 1 → 2"


def _write(path: Path, text: str) -> str:
    path.write_text(text)
    return str(path)


def test_diff_of_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    two = "robot1:\n  ros__parameters:\n    v: 1.5\n    s: x\nrobot2:\n  ros__parameters:\n    v: 1\n"
    a = _write(tmp_path / "a.yaml", two)
    b = _write(tmp_path / "b.yaml", "robot1:\n  ros__parameters:\n    v: 2.5\n    s: x\n")
    entries = '  - {name: v, type: double, value: 1.5}\n  - {name: s, type: string, value: "x"}\n'
    listed = _write(tmp_path / "l.yaml", "parameters:\n" + entries)
    assert main(["diff", a, a]) == 0
    assert capsys.readouterr().out == ""
    assert main(["diff", a, b]) == 1
    assert capsys.readouterr().out == "robot1:\n  v: 1.5 → 2.5\nrobot2:\n  v: only in " + a + " (1)\n"
    assert main(["diff", listed, a, "-o", "json"]) == 1
    blocks = json.loads(capsys.readouterr().out)
    assert [(k["node"], k["equal"]) for k in blocks] == [("robot1", True), ("robot2", False)]


def test_a_file_that_is_not_a_parameter_file_is_exit_2_with_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = _write(tmp_path / "a.yaml", "robot1:\n  ros__parameters:\n    v: 1.5\n")
    bad = _write(tmp_path / "bad.yaml", "robot1:\n  ros__parameters:\n    v: [1, 2\n")
    assert main(["diff", good, bad]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"paramdds: error: {bad}:") and err.count("\n") == 1
    notes = _write(tmp_path / "notes.txt", "just words\n")
    assert main(["diff", good, notes]) == 2
    assert f"{notes}:1:" in capsys.readouterr().err
    assert main(["diff", good, str(tmp_path / "missing.yaml")]) == 2
    assert "cannot read the file" in capsys.readouterr().err
    assert main(["diff", "r*", "s*"]) == 2
    assert "not another glob" in capsys.readouterr().err
