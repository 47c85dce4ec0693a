"""Values and descriptors as JSON: the bare, tagged and row forms, their shapes and round trips."""

import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from paramdds.core.jsonform import (
    descriptor_of_json,
    descriptor_of_row,
    descriptor_row,
    json_descriptor,
    json_scalar,
    json_tagged_value,
    json_value,
    value_of_json,
    value_of_row,
    value_of_tagged,
    value_row,
)
from paramdds.core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from paramdds.errors import ParamddsError, TypeMismatchError

T = ParameterType
PV = ParameterValue

ints = st.integers(min_value=INT64_MIN, max_value=INT64_MAX)
floats = st.floats(allow_nan=True, allow_infinity=True)
texts = st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=12)
SCALARS = {T.BOOL: st.booleans(), T.INTEGER: ints, T.DOUBLE: floats, T.STRING: texts}


@st.composite
def values(draw: st.DrawFn) -> ParameterValue:
    """Any value of any of the ten types (not_set included), non-finite doubles and bytes too."""
    ptype = draw(st.sampled_from(list(T)))
    if ptype is T.NOT_SET:
        return NOT_SET
    if ptype is T.BYTE_ARRAY:
        return PV.of(ptype, draw(st.binary(max_size=20)))
    element = ptype.element
    if element is None:
        return PV.of(ptype, draw(SCALARS[ptype]))
    return PV.of(ptype, draw(st.lists(SCALARS[element], max_size=6)))


@st.composite
def descriptors(draw: st.DrawFn) -> ParameterDescriptor:
    return ParameterDescriptor(
        draw(st.sampled_from(["a", "robot.max_velocity", "x_1"])),
        draw(st.sampled_from(list(T))),
        description=draw(texts),
        additional_constraints=draw(texts),
        read_only=draw(st.booleans()),
        dynamic_typing=draw(st.booleans()),
        integer_range=draw(st.none() | st.builds(IntegerRange, ints, ints, st.integers(0, 2**62))),
        floating_point_range=draw(st.none() | st.builds(FloatingPointRange, floats, floats, floats)),
        validators=tuple(
            draw(
                st.lists(
                    st.builds(
                        Validator,
                        st.sampled_from(["bounds", "one_of", "size_gt", "unique", "my::kind"]),
                        st.lists(values(), max_size=3).map(tuple),
                    ),
                    max_size=3,
                )
            )
        ),
    )


def same_descriptor(a: ParameterDescriptor, b: ParameterDescriptor) -> bool:
    """Equal, NaN included (a dataclass's == says NaN != NaN)."""
    text = json.dumps(json_descriptor(a, tagged=True), allow_nan=False)
    return a.name == b.name and text == json.dumps(json_descriptor(b, tagged=True), allow_nan=False)


def through_text(obj: object) -> object:
    """What a reader of the JSON text gets: strict JSON, no NaN literal."""
    return json.loads(json.dumps(obj, allow_nan=False))


# -- round trips --------------------------------------------------------------------------------


@given(values())
def test_a_bare_value_comes_back_with_its_type(v: ParameterValue) -> None:
    assert value_of_json(v.type, through_text(json_value(v))).same_as(v)


@given(values())
def test_a_tagged_value_comes_back_alone(v: ParameterValue) -> None:
    tagged = json_tagged_value(v)
    assert tagged == {"type": v.type.label, "value": json_value(v)}
    assert value_of_tagged(through_text(tagged)).same_as(v)


@given(values())
def test_a_value_row_comes_back_through_the_journals_json(v: ParameterValue) -> None:
    assert value_of_row(json.loads(json.dumps(value_row(v)))).same_as(v)


@given(descriptors())
def test_a_tagged_descriptor_comes_back(d: ParameterDescriptor) -> None:
    assert same_descriptor(descriptor_of_json(d.name, through_text(json_descriptor(d, tagged=True))), d)


@given(descriptors())
def test_a_descriptor_row_comes_back(d: ParameterDescriptor) -> None:
    assert same_descriptor(descriptor_of_row(d.name, json.loads(json.dumps(descriptor_row(d)))), d)


@given(descriptors())
def test_bare_and_tagged_descriptors_differ_in_key_order_and_arguments_only(d: ParameterDescriptor) -> None:
    bare, tagged = json_descriptor(d), json_descriptor(d, tagged=True)
    assert bare.keys() == tagged.keys()
    assert {k: v for k, v in bare.items() if k != "validators"} == {
        k: v for k, v in tagged.items() if k != "validators"
    }
    assert [[a["value"] for a in v["args"]] for v in tagged["validators"]] == [  # type: ignore[attr-defined]
        v["args"] for v in bare["validators"]  # type: ignore[attr-defined]
    ]


# -- the shapes (pinned: the CLI, the web API and the Zenoh payloads print them) ------------------


def test_bare_values() -> None:
    assert json_value(None) is None and json_value(NOT_SET) is None
    assert json.dumps(json_value(PV(T.DOUBLE, 2.0))) == "2.0"  # a double keeps its point
    assert [json_scalar(x) for x in (math.nan, math.inf, -math.inf, 1.5, "nan")] == [
        "nan",
        "inf",
        "-inf",
        1.5,
        "nan",
    ]
    assert json_value(PV(T.BYTE_ARRAY, b"\x00\x07\xff")) == [0, 7, 255]
    assert json_value(PV.of(T.DOUBLE_ARRAY, [1.0, math.nan])) == [1.0, "nan"]
    assert json_tagged_value(NOT_SET) == {"type": "not_set", "value": None}


def test_descriptor_key_orders() -> None:
    d = ParameterDescriptor(
        "a",
        T.DOUBLE,
        description="m/s",
        floating_point_range=FloatingPointRange(0.0, math.inf, 0.5),
        validators=(Validator("lt", (PV(T.DOUBLE, 9.0),)),),
    )
    bare = json_descriptor(d)
    assert list(bare) == [
        "type",
        "description",
        "read_only",
        "dynamic_typing",
        "integer_range",
        "floating_point_range",
        "additional_constraints",
        "validators",
    ]
    assert bare["floating_point_range"] == {"from_value": 0.0, "to_value": "inf", "step": 0.5}
    assert bare["validators"] == [{"kind": "lt", "args": [9.0]}]
    tagged = json_descriptor(d, tagged=True)
    assert list(tagged)[:3] == ["type", "description", "additional_constraints"]
    assert tagged["validators"] == [{"kind": "lt", "args": [{"type": "double", "value": 9.0}]}]


def test_rows_are_positional_and_keep_floats() -> None:
    d = ParameterDescriptor("a", T.INTEGER, "x", "y", True, False, IntegerRange(0, 10, 2), None)
    assert descriptor_row(d) == [int(T.INTEGER), "x", "y", True, False, [0, 10, 2], None, []]
    assert value_row(PV(T.BYTE_ARRAY, b"\x01\x02")) == [int(T.BYTE_ARRAY), [1, 2]]
    assert json.dumps(value_row(PV(T.DOUBLE, math.nan))) == f"[{int(T.DOUBLE)}, NaN]"


# -- reading what other writers send --------------------------------------------------------------


def test_doubles_may_come_as_integers_or_words() -> None:
    assert value_of_tagged({"type": "double", "value": 2}).same_as(PV(T.DOUBLE, 2.0))
    assert value_of_json(T.DOUBLE_ARRAY, [1, "-inf"]).same_as(PV.of(T.DOUBLE_ARRAY, [1.0, -math.inf]))
    assert value_of_json(T.STRING, "nan").same_as(PV(T.STRING, "nan"))  # a word only for doubles
    fr = {"from_value": 0, "to_value": "inf"}
    d = descriptor_of_json("a", {"type": "double", "floating_point_range": fr})
    assert d.floating_point_range == FloatingPointRange(0.0, math.inf, 0.0)
    assert descriptor_of_json("a", {}) == ParameterDescriptor("a")


def test_what_is_not_a_value_or_descriptor_is_refused() -> None:
    with pytest.raises(ParamddsError, match="not a value object"):
        value_of_tagged([1])
    with pytest.raises(ParamddsError, match="not a descriptor object"):
        descriptor_of_json("a", [])
    with pytest.raises(TypeMismatchError):
        value_of_json(T.INTEGER, "3")
    with pytest.raises(TypeMismatchError):
        value_of_json(T.BOOL, 1)
