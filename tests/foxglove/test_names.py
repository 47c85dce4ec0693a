"""Foxglove names and values, pure: every paramdds type round-trips through the protocol's JSON."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from paramdds.foxglove.names import BadValue, foxglove_name, from_foxglove, split_name, to_foxglove

T = ParameterType
SCALARS = {
    T.BOOL: st.booleans(),
    T.INTEGER: st.integers(min_value=INT64_MIN, max_value=INT64_MAX),
    T.DOUBLE: st.floats(allow_nan=True, allow_infinity=True),
    T.STRING: st.text(alphabet=st.characters(blacklist_categories=("Cs",))),
}


@st.composite
def values(draw: st.DrawFn) -> ParameterValue:
    ptype = draw(st.sampled_from([t for t in T if t is not T.NOT_SET]))
    if ptype is T.BYTE_ARRAY:
        return ParameterValue.of(ptype, draw(st.binary(max_size=40)))
    element = ptype.element
    if element is None:
        return ParameterValue.of(ptype, draw(SCALARS[ptype]))
    return ParameterValue.of(ptype, draw(st.lists(SCALARS[element], max_size=8)))


def over_the_wire(entry: dict[str, object]) -> dict[str, object]:
    """The entry as JSON text carries it (what the server sends, allow_nan=False) and read back."""
    out = json.loads(json.dumps(entry, allow_nan=False))
    assert isinstance(out, dict)
    return out


def as_javascript(obj: object) -> object:
    """What a JavaScript client sends back after reading ``obj``: ``2.0`` became ``2``, and
    ``-0.0`` became ``0`` (``JSON.stringify(-0)`` is ``"0"``)."""
    if isinstance(obj, float) and obj.is_integer():
        return int(obj)
    if isinstance(obj, list):
        return [as_javascript(x) for x in obj]
    if isinstance(obj, dict):
        return {k: as_javascript(v) for k, v in obj.items()}
    return obj


@given(values())
def test_every_type_round_trips_through_json(value: ParameterValue) -> None:
    entry = over_the_wire(to_foxglove("/arm.x", value))
    assert entry["name"] == "/arm.x"
    assert from_foxglove(entry, value.type).same_as(value)
    if not (isinstance(value.value, tuple) and not value.value):  # an empty list needs its type
        assert from_foxglove(entry).same_as(value)


def unsigned_zeros(value: ParameterValue) -> ParameterValue:
    """``value`` with every -0.0 as 0.0: what survives a JavaScript client's JSON."""
    if value.type is T.DOUBLE and value.value == 0.0:
        return ParameterValue.of(T.DOUBLE, 0.0)
    if value.type is T.DOUBLE_ARRAY:
        return ParameterValue.of(T.DOUBLE_ARRAY, [0.0 if x == 0.0 else x for x in value.value])  # type: ignore[union-attr]
    return value


@given(values())
def test_every_type_round_trips_through_a_javascript_client(value: ParameterValue) -> None:
    """A double stays a double: the hint (sent back as the client last saw it) restores 2 as 2.0.
    The one loss is JavaScript's own: a -0.0 comes back as 0.0."""
    entry = as_javascript(over_the_wire(to_foxglove("/arm.x", value)))
    assert isinstance(entry, dict)
    expected = unsigned_zeros(value)
    assert from_foxglove(entry, value.type).same_as(expected)
    without_hint = {k: v for k, v in entry.items() if k != "type"}
    if value.type is not T.BYTE_ARRAY:  # base64 text alone is a string: its node's type decides
        assert from_foxglove(without_hint, value.type).same_as(expected)



def test_the_hints_are_those_of_the_protocol() -> None:
    assert to_foxglove("/a.x", ParameterValue.of(T.DOUBLE, 1.0)) == {
        "name": "/a.x",
        "value": 1.0,
        "type": "float64",
    }
    assert to_foxglove("/a.x", ParameterValue.of(T.DOUBLE_ARRAY, [0.5])) == {
        "name": "/a.x",
        "value": [0.5],
        "type": "float64_array",
    }
    assert to_foxglove("/a.x", ParameterValue.of(T.BYTE_ARRAY, b"\x01\x02\xab")) == {
        "name": "/a.x",
        "value": "AQKr",
        "type": "byte_array",
    }
    for plain in (True, 4, "auto", [1, 2], ["a"], [True]):
        assert to_foxglove("/a.x", ParameterValue.from_python(plain)) == {"name": "/a.x", "value": plain}
    nan = to_foxglove("/a.x", ParameterValue.of(T.DOUBLE, math.nan))
    assert nan == {"name": "/a.x", "value": "nan", "type": "float64"}


def test_unset_has_no_value() -> None:
    assert to_foxglove("/a.x", None) == {"name": "/a.x"}
    assert to_foxglove("/a.x", NOT_SET) == {"name": "/a.x"}
    assert from_foxglove({"name": "/a.x"}) is NOT_SET
    assert from_foxglove({"name": "/a.x", "value": None}) is NOT_SET


def test_a_value_without_hint_takes_its_node_type_when_it_can() -> None:
    assert from_foxglove({"value": 2}, T.DOUBLE) == ParameterValue.of(T.DOUBLE, 2.0)
    assert from_foxglove({"value": []}, T.STRING_ARRAY) == ParameterValue.of(T.STRING_ARRAY, [])
    assert from_foxglove({"value": [1, 2]}, T.BYTE_ARRAY) == ParameterValue.of(T.BYTE_ARRAY, b"\x01\x02")
    # not of the node's type: taken as it is, for the node to judge
    assert from_foxglove({"value": "fast"}, T.DOUBLE) == ParameterValue.of(T.STRING, "fast")
    assert from_foxglove({"value": 1.5}, T.INTEGER) == ParameterValue.of(T.DOUBLE, 1.5)
    # a JavaScript double array without its hint: [1, 1.5]
    assert from_foxglove({"value": [1, 1.5]}) == ParameterValue.of(T.DOUBLE_ARRAY, [1.0, 1.5])


@pytest.mark.parametrize(
    ("entry", "why"),
    [
        ({"value": {"a": 1}}, "nested object"),
        ({"value": []}, "empty list"),
        ({"value": [1, "a"]}, "cannot make"),
        ({"value": "***", "type": "byte_array"}, "base64"),
        ({"value": [1, 2], "type": "byte_array"}, "base64"),
        ({"value": True, "type": "float64"}, "no booleans"),
        ({"value": [1.0, False], "type": "float64_array"}, "no booleans"),
        ({"value": "x", "type": "float64"}, "double"),
        ({"value": 1, "type": "int64"}, "unknown type hint"),
        ({"value": 2**70}, "64 bits"),
    ],
)
def test_what_is_no_parameter_value_is_refused_with_a_reason(entry: dict[str, object], why: str) -> None:
    with pytest.raises(BadValue, match=why):
        from_foxglove(entry)


@given(
    st.text(alphabet=st.characters(blacklist_characters=".", blacklist_categories=("Cs",)), min_size=1),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",)), min_size=1),
)
def test_names_split_at_the_first_dot(node: str, name: str) -> None:
    assert split_name(foxglove_name(node, name)) == (node, name)


def test_names_of_other_shapes_are_none() -> None:
    assert split_name("/s1/arm.pid.kp") == ("s1/arm", "pid.kp")
    for bad in ("arm.speed", "/arm", "/.speed", "/arm.", ""):
        assert split_name(bad) is None
