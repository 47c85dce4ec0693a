"""Listing by prefix and depth: rclcpp's algorithm, checked by examples and against a model."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.listing import list_names
from paramdds.core.table import ParameterTable

NAMES = ["a", "a.b", "a.b.c", "a.c", "b.x.y", "c"]


@pytest.fixture
def table() -> ParameterTable:
    t = ParameterTable("n")
    for name in reversed(NAMES):  # declaration order must not matter
        t.declare(name, 1)
    return t


@pytest.mark.parametrize(
    ("prefixes", "depth", "names", "found"),
    [
        ([], 0, NAMES, ["a", "a.b", "b.x"]),
        ([], 1, ["a", "c"], []),
        ([], 2, ["a", "a.b", "a.c", "c"], ["a"]),
        (["a"], 0, ["a", "a.b", "a.b.c", "a.c"], ["a", "a.b"]),
        (["a"], 1, ["a", "a.b", "a.c"], ["a"]),
        (["a.b"], 0, ["a.b", "a.b.c"], ["a", "a.b"]),
        (["b"], 1, [], []),  # b.x.y is two levels below b
        (["b"], 2, ["b.x.y"], ["b.x"]),
        (["b.x"], 1, ["b.x.y"], ["b.x"]),
        (["c", "a.b"], 0, ["a.b", "a.b.c", "c"], ["a", "a.b"]),  # sorted by name, not by prefix
        (["zz"], 0, [], []),
        (["a."], 0, [], []),  # ROS 2 matches prefix + "." literally
    ],
)
def test_list_matches_rclcpp(
    table: ParameterTable, prefixes: list[str], depth: int, names: list[str], found: list[str]
) -> None:
    result = table.list(prefixes, depth)
    assert list(result.names) == names
    assert list(result.prefixes) == found


def test_list_refuses_a_negative_depth(table: ParameterTable) -> None:
    from paramdds.errors import InvalidValueError

    with pytest.raises(InvalidValueError, match="depth"):
        table.list([], -1)


def model(names: list[str], prefixes: list[str], depth: int) -> tuple[list[str], list[str]]:
    """Listing stated in segments, written independently of the implementation."""

    def wanted(name: str) -> bool:
        segs = name.split(".")
        if not prefixes:
            return depth == 0 or len(segs) <= depth
        for prefix in prefixes:
            psegs = prefix.split(".")
            if segs == psegs:
                return True
            below = len(segs) - len(psegs)
            if segs[: len(psegs)] == psegs and below > 0 and (depth == 0 or below <= depth):
                return True
        return False

    listed = [n for n in sorted(set(names)) if wanted(n)]
    parents: list[str] = []
    for n in listed:
        segs = n.split(".")
        if len(segs) > 1 and ".".join(segs[:-1]) not in parents:
            parents.append(".".join(segs[:-1]))
    return listed, parents


segment = st.sampled_from(["a", "b", "ab", "a-b", "q/r"])
dotted = st.lists(segment, min_size=1, max_size=4).map(".".join)


@given(
    st.lists(dotted, max_size=12),
    st.lists(dotted | st.sampled_from(["", "a.", ".a"]), max_size=3),
    st.integers(min_value=0, max_value=5),
)
def test_list_agrees_with_a_brute_force_model(names: list[str], prefixes: list[str], depth: int) -> None:
    got_names, got_prefixes = list_names(sorted(set(names)), prefixes, depth)
    want_names, want_prefixes = model(names, prefixes, depth)
    assert got_names == want_names
    assert got_prefixes == want_prefixes
