"""Dumping a node's parameters: ROS 2 form, exact round trips, descriptors kept."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import (
    VALIDATOR_ARITY,
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    Validator,
)
from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.errors import InvalidNameError
from paramdds.formats.dump import dump_ros_params
from paramdds.formats.ros import load_ros_params_str, load_ros_text_full

Item = tuple[str, PV, "ParameterDescriptor | None"]


def test_dump_writes_the_ros2_layout() -> None:
    snapshot: list[Item] = [
        ("robot.enabled", PV(T.BOOL, True), None),
        ("robot.max_velocity", PV(T.DOUBLE, 1.0), None),
        ("robot.name", PV(T.STRING, "r1"), None),
        ("sensor.topics", PV(T.STRING_ARRAY, ("/scan", "on")), None),
        ("wheels", PV(T.INTEGER, 4), None),
    ]
    assert dump_ros_params("ns/robot1", snapshot) == (
        "/ns/robot1:\n"
        "  ros__parameters:\n"
        "    robot:\n"
        "      enabled: true\n"
        "      max_velocity: 1.0\n"
        "      name: r1\n"
        "    sensor:\n"
        '      topics: [/scan, "on"]\n'
        "    wheels: 4\n"
    )


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (PV(T.DOUBLE, 1.0), "1.0"),
        (PV(T.DOUBLE, 1e100), "1.0e+100"),
        (PV(T.DOUBLE, 1e-10), "1.0e-10"),
        (PV(T.DOUBLE, -1.5e-07), "-1.5e-07"),
        (PV(T.DOUBLE, 1.25e16), "1.25e+16"),
        (PV(T.DOUBLE, -0.0), "-0.0"),
        (PV(T.DOUBLE, math.nan), ".nan"),
        (PV(T.DOUBLE, -math.inf), "-.inf"),
        (PV(T.STRING, "1.5"), '"1.5"'),
        (PV(T.STRING, "0x1A"), '"0x1A"'),
        (PV(T.STRING, "yes"), '"yes"'),
        (PV(T.STRING, "null"), '"null"'),
        (PV(T.STRING, "~"), '"~"'),
        (PV(T.STRING, ""), '""'),
        (PV(T.STRING, "a: b # c"), '"a: b # c"'),
        (PV(T.STRING, 'line\nbreak\t"q"\\'), '"line\\nbreak\\t\\"q\\"\\\\"'),
        (PV(T.STRING, "héllo ☃"), '"héllo ☃"'),
        (PV(T.BYTE_ARRAY, b"\x00\x7f\xff"), "!byte_array [0, 127, 255]"),
        (PV(T.DOUBLE_ARRAY, ()), "!double_array []"),
        (PV(T.STRING_ARRAY, ()), "!string_array []"),
        (PV(T.NOT_SET, None), "!not_set"),
    ],
)
def test_values_are_written_so_they_read_back_as_the_same_type(value: PV, text: str) -> None:
    dumped = dump_ros_params("n", [("p", value, None)])
    assert dumped.splitlines()[-1] == f"    p: {text}"
    assert load_ros_params_str(dumped, "n")["p"].same_as(value)


def test_a_name_that_is_also_a_prefix_is_written_with_dotted_keys() -> None:
    snapshot: list[Item] = [("a", PV(T.INTEGER, 1), None), ("a.b", PV(T.INTEGER, 2), None)]
    dumped = dump_ros_params("n", snapshot)
    assert "    a: 1\n    a.b: 2\n" in dumped
    assert load_ros_params_str(dumped, "n") == {"a": PV(T.INTEGER, 1), "a.b": PV(T.INTEGER, 2)}


def test_descriptors_round_trip() -> None:
    desc = ParameterDescriptor(
        "robot.speed",
        T.DOUBLE,
        description='Top speed: "fast"\nsecond line',
        additional_constraints="0..5",
        read_only=True,
        floating_point_range=FloatingPointRange(0.0, 5.0, 0.5),
        validators=(
            Validator("bounds", (PV(T.DOUBLE, 0.0), PV(T.DOUBLE, 5.0))),
            Validator("one_of", (PV(T.DOUBLE_ARRAY, (1.0, 2.0)),)),
        ),
    )
    snapshot: list[Item] = [
        ("count", PV(T.INTEGER_ARRAY, ()), ParameterDescriptor("count", T.INTEGER_ARRAY)),
        ("n", PV(T.INTEGER, 3), ParameterDescriptor("n", T.INTEGER, integer_range=IntegerRange(0, 10, 2))),
        ("plain", PV(T.BOOL, False), None),
        ("robot.speed", PV(T.DOUBLE, 1.5), desc),
        ("x", PV(T.STRING, "v"), ParameterDescriptor("x", T.STRING, dynamic_typing=True)),
    ]
    dumped = dump_ros_params("n", snapshot, with_descriptors=True)
    assert load_ros_text_full(dumped, "n") == snapshot
    assert dump_ros_params("n", load_ros_text_full(dumped, "n"), with_descriptors=True) == dumped


def test_without_descriptors_the_dump_carries_none() -> None:
    snapshot: list[Item] = [("a", PV(T.INTEGER, 1), ParameterDescriptor("a", T.INTEGER, read_only=True))]
    dumped = dump_ros_params("n", snapshot)
    assert "paramdds__descriptors" not in dumped
    assert load_ros_text_full(dumped, "n") == [("a", PV(T.INTEGER, 1), None)]


def test_an_empty_node_dumps_and_loads() -> None:
    dumped = dump_ros_params("n", [])
    assert load_ros_params_str(dumped, "n") == {}


def test_bad_snapshots_are_refused() -> None:
    with pytest.raises(InvalidNameError):
        dump_ros_params("n", [("a", PV(T.INTEGER, 1), None), ("a", PV(T.INTEGER, 2), None)])
    with pytest.raises(InvalidNameError):
        dump_ros_params("n", [("", PV(T.INTEGER, 1), None)])


# --- the property: dump -> load -> dump is byte-identical ----------------------------------

_TRICKY = st.sampled_from(
    ["", " ", "on", "yes", "n", "null", "~", "1", "1.5", "0x1A", "1e3", "1:20", ".inf", "nan", "-", "- x",
     "#", "a: b", "[1]", "{a}", "'q'", '"q"', "\\", "\n", "\t", "\x85", "\u2028", "\ufeff", "é", "☃", "𝄞",
     "/scan", "!tag", "&a", "*a", "%", "@", "`", "|", ">"]
)  # fmt: skip
# Strings the value types accept: no lone surrogates, no NUL.
_CHARS = st.characters(exclude_categories=("Cs",), exclude_characters="\x00")
_STRINGS = st.one_of(_TRICKY, st.text(_CHARS, max_size=12))
_DOUBLES = st.floats(allow_nan=True, allow_infinity=True)
_INTS = st.integers(min_value=-(2**63), max_value=2**63 - 1)
_VALUES = st.one_of(
    st.booleans().map(lambda v: PV(T.BOOL, v)),
    _INTS.map(lambda v: PV(T.INTEGER, v)),
    _DOUBLES.map(lambda v: PV(T.DOUBLE, v)),
    _STRINGS.map(lambda v: PV(T.STRING, v)),
    st.binary(max_size=6).map(lambda v: PV(T.BYTE_ARRAY, v)),
    st.lists(st.booleans(), max_size=4).map(lambda v: PV(T.BOOL_ARRAY, tuple(v))),
    st.lists(_INTS, max_size=4).map(lambda v: PV(T.INTEGER_ARRAY, tuple(v))),
    st.lists(_DOUBLES, max_size=4).map(lambda v: PV(T.DOUBLE_ARRAY, tuple(v))),
    st.lists(_STRINGS, max_size=4).map(lambda v: PV(T.STRING_ARRAY, tuple(v))),
)
_SEGMENT = st.one_of(
    st.sampled_from(["a", "b", "robot", "1", "on", "x y", "é", "ros__parameters"]),
    st.text(_CHARS.filter(lambda c: c != "."), min_size=1, max_size=5),
)
_NAMES = st.lists(_SEGMENT, min_size=1, max_size=3).map(".".join)


@st.composite
def _descriptors(draw: st.DrawFn, name: str, value: PV) -> ParameterDescriptor | None:
    if draw(st.booleans()):
        return None
    kinds = draw(st.lists(st.sampled_from(sorted(VALIDATOR_ARITY)), max_size=2))
    validators = tuple(
        Validator(kind, tuple(draw(_VALUES) for _ in range(VALIDATOR_ARITY[kind]))) for kind in kinds
    )
    int_range = draw(st.none() | st.tuples(_INTS, _INTS, _INTS).map(lambda r: IntegerRange(*r)))
    fp_range = draw(st.none() | st.tuples(_DOUBLES, _DOUBLES, _DOUBLES).map(lambda r: FloatingPointRange(*r)))
    return ParameterDescriptor(
        name,
        value.type,
        description=draw(_STRINGS),
        additional_constraints=draw(_STRINGS),
        read_only=draw(st.booleans()),
        dynamic_typing=draw(st.booleans()),
        integer_range=int_range,
        floating_point_range=fp_range,
        validators=validators,
    )


@st.composite
def _snapshots(draw: st.DrawFn) -> list[Item]:
    names = draw(st.lists(_NAMES, max_size=8, unique=True))
    out: list[Item] = []
    for name in sorted(names):
        value = draw(_VALUES)
        out.append((name, value, draw(_descriptors(name, value))))
    return out


@settings(max_examples=200, deadline=None)
@given(_snapshots(), st.booleans())
def test_dump_load_dump_is_byte_identical(snapshot: list[Item], with_descriptors: bool) -> None:
    first = dump_ros_params("ns/robot1", snapshot, with_descriptors=with_descriptors)
    loaded = load_ros_text_full(first, "ns/robot1")
    assert dump_ros_params("ns/robot1", loaded, with_descriptors=with_descriptors) == first
    assert [name for name, _, _ in loaded] == [name for name, _, _ in snapshot]
    for (_, value, desc), (_, back, back_desc) in zip(snapshot, loaded, strict=True):
        assert back.same_as(value)
        if with_descriptors and desc is not None and not any(math.isnan(x) for x in _floats(desc)):
            assert back_desc == desc


def _floats(desc: ParameterDescriptor) -> list[float]:
    out: list[float] = []
    if desc.floating_point_range is not None:
        r = desc.floating_point_range
        out += [r.from_value, r.to_value, r.step]
    for v in desc.validators:
        for a in v.args:
            vals = a.value if isinstance(a.value, tuple) else (a.value,)
            out += [x for x in vals if isinstance(x, float)]
    return out
