"""--since, --until and NODE@…: revisions, ISO 8601 times and ages; anything else is exit 2."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.cli._when import Point, parse_point, parse_time, split_at
from paramdds.exits import UsageError

NOW = 1_800_000_000.0


def test_an_integer_is_a_revision() -> None:
    assert parse_point("7") == Point(revision=7)
    assert parse_point("0") == Point(revision=0)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("2027-01-15T08:00:00Z", 1_800_000_000.0),
        ("2027-01-15T08:00:00+00:00", 1_800_000_000.0),
        ("2027-01-15T09:00:00+01:00", 1_800_000_000.0),
        ("2027-01-15 08:00", 1_800_000_000.0),  # no offset: UTC
    ],
)
def test_iso_times(text: str, expected: float) -> None:
    assert parse_time(text) == expected


@pytest.mark.parametrize(
    ("age", "seconds"), [("90s", 90), ("10m", 600), ("2h", 7200), ("3d", 259200), ("1w", 604800)]
)
def test_ages_count_back_from_now(age: str, seconds: float) -> None:
    assert parse_point(age, now=NOW) == Point(time_s=NOW - seconds)


@pytest.mark.parametrize("text", ["", "yesterday", "-3", "10x", "2026-13-40", "1.5", "2h ago"])
def test_anything_else_is_a_usage_error_of_one_line(text: str) -> None:
    with pytest.raises(UsageError) as info:
        parse_point(text, option="--since")
    assert str(info.value).startswith("--since: not a revision")
    assert "\n" not in str(info.value)


@given(st.text(max_size=30))
def test_any_text_is_a_point_or_a_usage_error(text: str) -> None:
    try:
        point = parse_point(text, now=NOW)
    except UsageError:
        return
    assert (point.revision is None) != (point.time_s is None)


def test_node_at_a_point() -> None:
    assert split_at("robot1") == ("robot1", None)
    assert split_at("robot1@4") == ("robot1", Point(revision=4))
    assert split_at("site/robot1@2027-01-15T08:00:00Z") == ("site/robot1", Point(time_s=NOW))
    with pytest.raises(UsageError, match="robot1@: not a revision"):
        split_at("robot1@soon")
    with pytest.raises(UsageError, match="no node before"):
        split_at("@4")
