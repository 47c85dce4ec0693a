"""The conformance suite: every case from the upstream test suites, run against the pure core.

A failure names the case, its upstream source and what the core did instead. A
deliberate difference must quote a sentence of the "Fixed" list in docs/semantics.md.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from . import cases_gpl, cases_rcl_yaml, cases_rclcpp, cases_rclpy
from .runner import Case, run

ALL: list[Case] = [*cases_rcl_yaml.CASES, *cases_rclcpp.CASES, *cases_rclpy.CASES, *cases_gpl.CASES]
SEMANTICS_PAGE = Path(__file__).resolve().parents[2] / "docs" / "semantics.md"


def _flat(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.mark.parametrize("case", ALL, ids=[c.id for c in ALL])
def test_case(case: Case) -> None:
    problem = run(case)
    assert problem is None, f"{case.id} ({case.source}): {problem}"


def test_case_ids_are_unique_and_the_suite_is_broad() -> None:
    ids = [c.id for c in ALL]
    assert len(ids) == len(set(ids))
    assert len(ALL) >= 150


def _semantics_page() -> str:
    return _flat(SEMANTICS_PAGE.read_text(encoding="utf-8"))


def test_the_semantics_page_counts_match_the_suite() -> None:
    text = _semantics_page()
    deliberate = sum(1 for c in ALL if c.deliberate)
    assert f"holds {len(ALL)} cases" in text
    assert f"{len(ALL) - deliberate} agree with upstream; {deliberate} are deliberate differences" in text


def test_every_deliberate_difference_is_in_the_semantics_page_fixed_list() -> None:
    text = _semantics_page()
    fixed = text[text.index("**Fixed**") : text.index("**Conformance.**")]
    deliberate = [c for c in ALL if c.deliberate]
    assert deliberate, "the suite pins its deliberate differences"
    for case in deliberate:
        assert _flat(case.deliberate) in fixed, f"{case.id}: docs/semantics.md lacks {case.deliberate!r}"
        assert case.ours is not None and case.ours != case.expect


def test_the_runner_reports_a_disagreement() -> None:
    # Positive control for the runner itself: a case with a wrong expectation must fail.
    text = "p:\n  ros__parameters:\n    a: 1\n"
    wrong = Case("control", "none", "yaml", (text, "p"), {"a": ("integer", 2)})
    assert run(wrong) == "a = integer 1, upstream integer 2"
