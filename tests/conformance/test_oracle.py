"""ROS 2 itself as the oracle: random operation sequences and parameter files, run through
real rclpy / rcl (from the PyPI wheels) and through our core, must agree or hit a listed
difference (see tests/conformance/ros_oracle.py and docs/semantics.md, "Conformance").
"""

from __future__ import annotations

import os
import random
import re
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from . import rcl_yaml as ry
from . import ros_oracle as ro
from .test_conformance import SEMANTICS_PAGE, _flat
from .test_realworld import REALWORLD

pytestmark = pytest.mark.slow

SEQUENCES = 3000
LENGTH = 12


def _require_ros() -> None:
    missing = ro.ros_missing()
    if missing is None:
        return
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI needs real ROS 2 for the oracle: {missing}")
    pytest.skip(missing)


@pytest.fixture(scope="module")
def ros_context() -> Iterator[Any]:
    _require_ros()
    with ro.ros_session() as context:
        yield context


def _fixed_list() -> str:
    text = _flat(SEMANTICS_PAGE.read_text(encoding="utf-8"))
    return text[text.index("**Fixed**") : text.index("**Conformance.**")]


def test_random_sequences_agree_with_rclpy_or_hit_a_listed_difference() -> None:
    _require_ros()
    start = time.monotonic()
    run = ro.run_sequences_in_children(SEQUENCES, LENGTH)  # rclpy's rare teardown crash: see there
    problems: list[str] = []
    hits: Counter[str] = Counter()
    ops = clean = 0
    assert sorted(run.verdicts) == list(range(SEQUENCES))
    for verdict in run.verdicts.values():
        ops += verdict.ops
        hits.update(verdict.differences)
        clean += not verdict.differences and verdict.problem is None
        if verdict.problem is not None:
            problems.append(verdict.problem)
    print(
        f"\n{SEQUENCES} sequences, {ops} operations, {clean} sequences agree in every operation, "
        f"listed differences hit: {dict(hits)}, rclpy crashes survived: {run.crashes or 'none'}, "
        f"{time.monotonic() - start:.1f} s"
    )
    assert not problems, f"{len(problems)} unexplained disagreements; first:\n" + "\n".join(problems[:3])
    # sequences stop where the two tables diverge; most operations must still be compared
    assert ops > SEQUENCES * LENGTH // 2


def test_a_crashed_oracle_child_is_started_again_where_it_died() -> None:
    _require_ros()
    run = ro.run_sequences_in_children(8, 4, env={"PARAMDDS_ORACLE_CRASH_AT": "5"})
    assert run.crashes == ["sequence 5: SIGSEGV"]
    assert sorted(run.verdicts) == list(range(8))
    with pytest.raises(RuntimeError, match="stopped at sequence 5"):
        ro.run_sequences_in_children(8, 4, max_crashes=0, env={"PARAMDDS_ORACLE_CRASH_AT": "5"})


def test_every_difference_is_documented() -> None:
    fixed = _fixed_list()
    for diff in ro.DIFFERENCES:
        assert bool(diff.fixed) != bool(diff.rclcpp), diff.id
        if diff.fixed:
            assert _flat(diff.fixed) in fixed, (
                f"{diff.id}: docs/semantics.md's Fixed list lacks {diff.fixed!r}"
            )
        else:
            assert re.search(r"rclcpp/src/rclcpp/\S+\.cpp, \w+", diff.rclcpp), diff.id


def test_an_unlisted_disagreement_fails() -> None:
    # Positive control: outcomes that differ in kind do not agree, and nothing explains them.
    assert not ro.agree(("fail", "READ_ONLY"), ("fail", ro.ErrorCode.NOT_FOUND))
    assert not ro.agree(("ok", ("integer", 1)), ("ok", ("integer", 2)))
    assert ro.agree(("ok", ("double", float("nan"))), ("ok", ("double", float("nan"))))
    op = ro.Op("get", ("a",))
    sides = ro.Sides(node=None, table=ro.ParameterTable("n"), allow_undeclared=False, log=[op])
    sides.before = {"a": ro.ParameterDescriptor("a", ro.T.INTEGER)}
    verdict = ro.Verdict()
    assert not ro._explain(sides, op, ("ok", ("integer", 1)), ("ok", ("integer", 2)), 0, verdict)
    assert verdict.differences == [] and verdict.problem is not None and "seed 0" in verdict.problem
    text = "robot:\n  ros__parameters:\n    a: 1\n"
    assert ry.explain(text, ("ok", {"a": ("integer", 1)}), ("ok", {"a": ("integer", 2)})) is None
    tiny = ("ok", {"a": ("string", "1e-310")}), ("ok", {"a": ("double", 1e-310)})
    assert ry.explain(text, *tiny) == ry.SUBNORMAL


FILES = 1500


def _compare_file(path: Path, text: str, nodes: tuple[str, ...], hits: Counter[str]) -> list[str]:
    ros, ours = ry.rcl_load(path, nodes), ry.our_load(text, nodes)
    problems = []
    for node in nodes:
        if ro.same_payload(ros[node], ours[node]):
            continue
        why = ry.explain(text, ros[node], ours[node])
        if why is None:
            problems.append(f"{path.name} for {node}:\n{text}\nrcl: {ros[node]}\nours: {ours[node]}")
        else:
            hits[why] += 1
    return problems


def test_generated_parameter_files_agree_with_rcl(ros_context: Any, tmp_path: Path) -> None:
    start = time.monotonic()
    problems: list[str] = []
    hits: Counter[str] = Counter()
    for i in range(FILES):
        text = ry.random_file(random.Random(i))
        path = tmp_path / f"seed{i}.yaml"
        path.write_text(text, encoding="utf-8")
        problems += _compare_file(path, text, ry.NODES, hits)
    print(f"\n{FILES} files x {len(ry.NODES)} nodes, listed differences: {dict(hits)}, "
          f"{time.monotonic() - start:.1f} s")
    assert not problems, f"{len(problems)} unexplained; first:\n" + "\n".join(problems[:3])
    assert sum(hits.values()) < FILES * len(ry.NODES) // 2, "most files must be compared value by value"


REAL_FILES = sorted(
    p for p in REALWORLD.glob("*.yaml") if "ros__parameters" in p.read_text(encoding="utf-8")
)


@pytest.mark.parametrize("path", REAL_FILES, ids=[p.name for p in REAL_FILES])
def test_real_parameter_files_agree_with_rcl(ros_context: Any, path: Path) -> None:
    assert len(REAL_FILES) >= 6, f"the real parameter files of {REALWORLD}"
    text = path.read_text(encoding="utf-8")
    nodes = ry.node_names(text)
    hits: Counter[str] = Counter()
    problems = _compare_file(path, text, nodes, hits)
    assert not problems, "\n".join(problems[:2])
    assert not hits, f"a real file should agree outright: {dict(hits)}"
    loaded = ry.our_load(text, nodes)
    assert sum(len(v[1]) for v in loaded.values() if v[0] == "ok") > 0, "the file configures its nodes"


def test_every_file_difference_is_documented() -> None:
    fixed = _fixed_list()
    for sentence in ry.DIFFERENCES:
        assert _flat(sentence) in fixed, f"docs/semantics.md's Fixed list lacks {sentence!r}"
