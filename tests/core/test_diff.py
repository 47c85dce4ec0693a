"""The comparison under paramdds diff: symmetric, exact, and empty exactly when the sides are the same."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.diff import DiffKind, compare, difference_json
from paramdds.core.values import ParameterType, ParameterValue

values = st.one_of(
    st.integers(-5, 5).map(lambda i: ParameterValue(ParameterType.INTEGER, i)),
    st.sampled_from([0.0, -0.0, 1.5, math.nan]).map(lambda f: ParameterValue(ParameterType.DOUBLE, f)),
    st.sampled_from(["a", "b"]).map(lambda s: ParameterValue(ParameterType.STRING, s)),
)
sides = st.dictionaries(st.sampled_from(["a.x", "a.y", "b", "c.z"]), values, max_size=4)


@given(sides)
def test_a_side_equals_itself(a: dict[str, ParameterValue]) -> None:
    assert compare(a, dict(a)) == []


@given(sides, sides)
def test_symmetric_and_exact(a: dict[str, ParameterValue], b: dict[str, ParameterValue]) -> None:
    ab, ba = compare(a, b), compare(b, a)
    assert [(d.name, d.a, d.b) for d in ab] == [(d.name, d.b, d.a) for d in ba]
    names = {d.name for d in ab}
    assert names == {n for n in a.keys() | b.keys() if n not in a or n not in b or not a[n].same_as(b[n])}
    assert [d.name for d in ab] == sorted(names)
    for d in ab:
        kind = DiffKind.ONLY_A if d.b is None else DiffKind.ONLY_B if d.a is None else DiffKind.CHANGED
        assert d.kind is kind


def test_an_integer_is_not_a_double() -> None:
    a = {"v": ParameterValue(ParameterType.DOUBLE, 2.0)}
    b = {"v": ParameterValue(ParameterType.INTEGER, 2)}
    assert [d.kind for d in compare(a, b)] == [DiffKind.CHANGED]


def test_json_leaves_out_the_side_that_lacks_it() -> None:
    (d,) = compare({"v": ParameterValue(ParameterType.INTEGER, 1)}, {})
    assert difference_json(d) == {"name": "v", "kind": "only_a", "a": 1}
