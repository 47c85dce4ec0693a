"""ROS 2 itself as the oracle: random operation sequences and parameter files, run through
real rclpy / rcl (from the PyPI wheels) and through our core, must agree or hit a listed
difference (see tests/conformance/ros_oracle.py and docs/semantics.md, "Conformance").
"""

from __future__ import annotations

import os
import re
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from . import ros_oracle as ro
from .test_conformance import SEMANTICS_PAGE, _flat

SEQUENCES = 3000
LENGTH = 12
REALWORLD = Path(__file__).resolve().parents[3] / "shared" / "realworld"
if not REALWORLD.is_dir():
    REALWORLD = Path("/work/shared/realworld")


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


def test_random_sequences_agree_with_rclpy_or_hit_a_listed_difference(ros_context: Any) -> None:
    start = time.monotonic()
    problems: list[str] = []
    hits: Counter[str] = Counter()
    ops = clean = 0
    for i in range(SEQUENCES):
        verdict = ro.run_sequence(ros_context, i, seed=i, length=LENGTH)
        ops += verdict.ops
        hits.update(verdict.differences)
        clean += not verdict.differences and verdict.problem is None
        if verdict.problem is not None:
            problems.append(verdict.problem)
    print(
        f"\n{SEQUENCES} sequences, {ops} operations, {clean} sequences agree in every operation, "
        f"listed differences hit: {dict(hits)}, {time.monotonic() - start:.1f} s"
    )
    assert not problems, f"{len(problems)} unexplained disagreements; first:\n" + "\n".join(problems[:3])
    # sequences stop where the two tables diverge; most operations must still be compared
    assert ops > SEQUENCES * LENGTH // 2


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
