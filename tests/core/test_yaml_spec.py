"""Specs in generate_parameter_library's format, and declaring them on a table."""

from __future__ import annotations

from pathlib import Path

import pytest

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from paramdds.core.table import ParameterTable
from paramdds.core.values import NOT_SET
from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.errors import FileFormatError, InvalidValueError
from paramdds.formats.spec import SpecEntry, declare_spec, load_spec, load_spec_str

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def spec(body: str) -> str:
    return "ns:\n" + "".join(f"  {line}\n" for line in body.splitlines())


def one(body: str) -> SpecEntry:
    (entry,) = load_spec_str(spec(body))
    return entry


def test_root_is_a_namespace_and_groups_nest() -> None:
    entries = load_spec_str(spec("a:\n  b:\n    type: int\n    default_value: 1\nc:\n  type: bool\n"))
    assert [e.name for e in entries] == ["a.b", "c"]


def test_leaf_fields_fill_the_descriptor() -> None:
    entry = one(
        "speed:\n"
        "  type: double\n"
        "  default_value: 2\n"
        "  description: Top speed\n"
        "  read_only: true\n"
        "  additional_constraints: be careful\n"
        "  validation:\n"
        "    bounds<>: [0, 5]\n"
    )
    assert entry.default == PV(T.DOUBLE, 2.0)
    assert entry.descriptor == ParameterDescriptor(
        "speed",
        T.DOUBLE,
        description="Top speed",
        additional_constraints="be careful",
        read_only=True,
        floating_point_range=FloatingPointRange(0.0, 5.0),
        validators=(Validator("bounds", (PV(T.DOUBLE, 0.0), PV(T.DOUBLE, 5.0))),),
    )


def test_integer_bounds_fill_the_integer_range() -> None:
    entry = one("n:\n  type: int\n  default_value: 3\n  validation:\n    bounds<>: [1, 9]\n")
    assert entry.descriptor.integer_range == IntegerRange(1, 9)


@pytest.mark.parametrize(
    ("body", "validator"),
    [
        ("type: int\nvalidation:\n  gt<>: [0]", Validator("gt", (PV(T.INTEGER, 0),))),
        ("type: double\nvalidation:\n  lt_eq<>: [1]", Validator("lt_eq", (PV(T.DOUBLE, 1.0),))),
        (
            "type: string\nvalidation:\n  one_of<>: [[a, b]]",
            Validator("one_of", (PV(T.STRING_ARRAY, ("a", "b")),)),
        ),
        ("type: int\nvalidation:\n  one_of<>: [[1, 2]]", Validator("one_of", (PV(T.INTEGER_ARRAY, (1, 2)),))),
        ("type: string_array\nvalidation:\n  unique<>: null", Validator("unique")),
        ("type: string_array\nvalidation:\n  not_empty<>: []", Validator("not_empty")),
        ("type: int_array\nvalidation:\n  size_gt<>: [2]", Validator("size_gt", (PV(T.INTEGER, 2),))),
        ("type: int_array\nvalidation:\n  fixed_size<>: [3]", Validator("fixed_size", (PV(T.INTEGER, 3),))),
        (
            "type: string_array\nvalidation:\n  subset_of<>: [[x, y]]",
            Validator("subset_of", (PV(T.STRING_ARRAY, ("x", "y")),)),
        ),
        (
            "type: double_array\nvalidation:\n  element_bounds<>: [0, 1.5]",
            Validator("element_bounds", (PV(T.DOUBLE, 0.0), PV(T.DOUBLE, 1.5))),
        ),
        (
            "type: int_array\nvalidation:\n  lower_element_bounds<>: [0]",
            Validator("lower_element_bounds", (PV(T.INTEGER, 0),)),
        ),
        ("type: double\nvalidation:\n  upper_bounds: [2.0]", Validator("upper_bounds", (PV(T.DOUBLE, 2.0),))),
    ],
)
def test_validators_are_spelled_as_generate_parameter_library_does(body: str, validator: Validator) -> None:
    entry = one("p:\n" + "".join(f"  {line}\n" for line in body.splitlines()))
    assert entry.descriptor.validators == (validator,)


def test_fixed_strings_and_arrays_get_a_size_limit() -> None:
    name = one("name:\n  type: string_fixed_8\n  default_value: abc\n")
    assert name.descriptor.type is T.STRING
    assert name.descriptor.validators == (Validator("size_lt", (PV(T.INTEGER, 9),)),)
    arr = one("xs:\n  type: double_array_fixed_3\n  default_value: []\n")
    assert arr.descriptor.type is T.DOUBLE_ARRAY
    assert arr.default == PV(T.DOUBLE_ARRAY, ())
    assert arr.descriptor.validators == (Validator("size_lt", (PV(T.INTEGER, 4),)),)


def test_none_is_dynamically_typed() -> None:
    entry = one("any:\n  type: none\n  default_value: 1:20\n")
    assert entry.descriptor.dynamic_typing and entry.descriptor.type is T.NOT_SET
    assert entry.default == PV(T.STRING, "1:20")


def test_a_leaf_without_default_is_required() -> None:
    entry = one("port:\n  type: int\n")
    assert entry.required and entry.default is NOT_SET


@pytest.mark.parametrize(
    ("body", "line", "match"),
    [
        ("p:\n  type: float\n", 3, r"'p': unknown type 'float'"),
        ("p:\n  type: int\n  unit: m\n", 4, r"'p': unknown key 'unit'"),
        ("p:\n  type: int\n  validation:\n    between<>: [1, 2]\n", 5, r"'p': unknown validator 'between'"),
        ("p:\n  type: int\n  validation:\n    bounds<>: [1]\n", 5, r"'p': validator bounds takes 2"),
        ("p:\n  type: int\n  validation:\n    bounds<>: 1\n", 5, r"'p': arguments of bounds must be a list"),
        ("p:\n  type: int\n  validation:\n    gt<>: [1.5]\n", 5, r"'p': expected an integer"),
        (
            "p:\n  type: bool\n  validation:\n    gt<>: [1]\n",
            5,
            r"'p': validator gt<> does not apply to a bool",
        ),
        (
            "p:\n  type: int\n  validation:\n    unique<>: null\n",
            5,
            r"'p': validator unique<> does not apply",
        ),
        ("p:\n  type: int\n  default_value: 1.5\n", 4, r"'p': expected an integer, got double"),
        ("p:\n  type: int_array\n  default_value: [1, x]\n", 4, r"'p': expected an integer, got string"),
        ("__map_joints:\n  x:\n    type: int\n", 3, r"__map_joints needs a string_array parameter 'joints'"),
        ("__other:\n  x:\n    type: int\n", 2, r"'__other' is not a parameter name"),
        ("p: 5\n", 2, r"'p': expected a map with 'type'"),
    ],
)
def test_spec_errors_name_the_parameter_and_line(body: str, line: int, match: str) -> None:
    with pytest.raises(FileFormatError, match=match) as info:
        load_spec_str(spec(body), source="spec.yaml")
    assert (info.value.file, info.value.line) == ("spec.yaml", line)


def test_a_spec_has_exactly_one_root() -> None:
    with pytest.raises(FileFormatError, match="exactly one root"):
        load_spec_str("a:\n  p:\n    type: int\nb:\n  q:\n    type: int\n")


def test_example_spec_loads() -> None:
    entries = {e.name: e for e in load_spec(EXAMPLES / "robot_spec.yaml")}
    assert entries["robot.max_velocity"].descriptor.floating_point_range == FloatingPointRange(0.0, 5.0)
    assert entries["robot.name"].required
    assert entries["robot.wheel_count"].descriptor.read_only
    assert entries["sensor.topics"].default == PV(T.STRING_ARRAY, ("/scan", "/imu"))


def test_declare_spec_uses_overrides_for_required_parameters() -> None:
    entries = load_spec(EXAMPLES / "robot_spec.yaml")
    table = ParameterTable("robot1", overrides={"robot.name": PV(T.STRING, "r2d2")})
    declare_spec(table, entries)
    assert table.get("robot.name") == PV(T.STRING, "r2d2")
    assert table.get("robot.max_velocity") == PV(T.DOUBLE, 1.5)
    assert table.describe_one("robot.wheel_count").read_only


def test_declare_spec_names_every_missing_required_parameter_and_declares_nothing() -> None:
    entries = load_spec_str(
        spec("a:\n  type: int\n  default_value: 1\nb:\n  type: int\nc:\n  type: string\n")
    )
    table = ParameterTable("n")
    with pytest.raises(InvalidValueError, match=r"'b'.*'c'"):
        declare_spec(table, entries)
    assert not table.has("a")
