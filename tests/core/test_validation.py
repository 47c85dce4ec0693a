"""Ranges (ROS 2 step rules), validators, and checking descriptors."""

import math

import pytest

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from paramdds.core.validation import check_descriptor, check_validator, validate
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import InvalidValueError, OutOfRangeError, TypeMismatchError

T = ParameterType
V = ParameterValue.from_python


def desc(ptype: ParameterType, *validators: Validator, **kw: object) -> ParameterDescriptor:
    return ParameterDescriptor("p", ptype, validators=validators, **kw)  # type: ignore[arg-type]


def val(kind: str, *args: object) -> Validator:
    return Validator(kind, tuple(V(a) for a in args))


# --- ROS 2 ranges ---------------------------------------------------------------------------------

INT_RANGE = desc(T.INTEGER, integer_range=IntegerRange(1, 10, 4))  # grid 1, 5, 9 — and 10, a bound


@pytest.mark.parametrize("v", [1, 5, 9, 10])
def test_integer_range_accepts_grid_points_and_both_bounds(v: int) -> None:
    validate("p", V(v), INT_RANGE)


@pytest.mark.parametrize("v", [0, 2, 8, 11, -3])
def test_integer_range_refuses_off_grid_and_outside(v: int) -> None:
    with pytest.raises(OutOfRangeError) as info:
        validate("p", V(v), INT_RANGE)
    assert info.value.message == f"Parameter 'p' with value {v} must be within [1, 10] in steps of 4"


def test_integer_step_zero_is_continuous() -> None:
    d = desc(T.INTEGER, integer_range=IntegerRange(-5, 5, 0))
    for v in range(-5, 6):
        validate("p", V(v), d)
    with pytest.raises(OutOfRangeError, match=r"within \[-5, 5\]$"):
        validate("p", V(6), d)


def test_integer_range_applies_to_each_array_element() -> None:
    d = desc(T.INTEGER_ARRAY, integer_range=IntegerRange(0, 10, 2))
    validate("p", V([0, 2, 10]), d)
    with pytest.raises(OutOfRangeError, match=r"value \[0, 3\]"):
        validate("p", V([0, 3]), d)


FLOAT_RANGE = desc(T.DOUBLE, floating_point_range=FloatingPointRange(-0.3, 1.0, 0.1))


@pytest.mark.parametrize("v", [-0.3, 1.0, 0.0, 0.1, 0.30000000000000004, 0.7, 0.7 + 1e-9])
def test_double_range_accepts_grid_points_within_tolerance(v: float) -> None:
    validate("p", V(v), FLOAT_RANGE)


@pytest.mark.parametrize("v", [0.05, 0.71, 1.01, -0.31, math.nan, math.inf, -math.inf])
def test_double_range_refuses_off_grid_outside_and_non_finite(v: float) -> None:
    with pytest.raises(OutOfRangeError, match=r"must be within \[-0.3, 1.0\] in steps of 0.1"):
        validate("p", V(v), FLOAT_RANGE)


def test_a_double_on_a_bound_is_accepted_even_off_grid() -> None:
    d = desc(T.DOUBLE, floating_point_range=FloatingPointRange(0.0, 1.05, 0.1))
    validate("p", V(1.05), d)
    with pytest.raises(OutOfRangeError):
        validate("p", V(1.04), d)


def test_infinity_never_passes_a_range_even_an_infinite_one() -> None:
    d = desc(T.DOUBLE, floating_point_range=FloatingPointRange(0.0, math.inf, 0.0))
    validate("p", V(1e300), d)
    with pytest.raises(OutOfRangeError):
        validate("p", V(math.inf), d)


# --- validators -----------------------------------------------------------------------------------


def test_the_bounds_message_names_parameter_value_and_rule() -> None:
    d = ParameterDescriptor("robot.max_velocity", T.DOUBLE, validators=(val("bounds", 0.0, 5.0),))
    validate("robot.max_velocity", V(5.0), d)
    with pytest.raises(OutOfRangeError) as info:
        validate("robot.max_velocity", V(7.5), d)
    assert (
        info.value.message == "Parameter 'robot.max_velocity' with value 7.5 must be within bounds [0.0, 5.0]"
    )


@pytest.mark.parametrize(
    ("validator", "good", "bad", "rule"),
    [
        (val("bounds", 1, 3), 3, 4, "be within bounds [1, 3]"),
        (val("lower_bounds", 1), 1, 0, "be at least 1"),
        (val("upper_bounds", 1), 1, 2, "be at most 1"),
        (val("gt", 1), 2, 1, "be greater than 1"),
        (val("lt", 1), 0, 1, "be less than 1"),
        (val("gt_eq", 1), 1, 0, "be greater than or equal to 1"),
        (val("lt_eq", 1), 1, 2, "be less than or equal to 1"),
    ],
)
def test_comparison_validators_on_integers(validator: Validator, good: int, bad: int, rule: str) -> None:
    d = desc(T.INTEGER, validator)
    validate("p", V(good), d)
    with pytest.raises(OutOfRangeError) as info:
        validate("p", V(bad), d)
    assert info.value.message == f"Parameter 'p' with value {bad} must {rule}"


@pytest.mark.parametrize("kind", ["bounds", "lower_bounds", "upper_bounds", "gt", "lt", "gt_eq", "lt_eq"])
@pytest.mark.parametrize("v", [math.nan, math.inf, -math.inf])
def test_nan_and_inf_never_pass_a_bound_or_comparison(kind: str, v: float) -> None:
    args = (-1e308, 1e308) if kind == "bounds" else (0.0,)
    with pytest.raises(OutOfRangeError):
        validate("p", V(v), desc(T.DOUBLE, val(kind, *args)))


def test_an_integer_bound_applies_to_a_double() -> None:
    d = desc(T.DOUBLE, val("bounds", 0, 5))
    validate("p", V(4.5), d)
    with pytest.raises(OutOfRangeError, match="within bounds \\[0, 5\\]"):
        validate("p", V(5.5), d)


def test_one_of_on_strings_and_numbers() -> None:
    d = desc(T.STRING, val("one_of", ["slow", "fast"]))
    validate("p", V("fast"), d)
    with pytest.raises(InvalidValueError) as info:
        validate("p", V("warp"), d)
    assert info.value.message == "Parameter 'p' with value 'warp' must be one of ['slow', 'fast']"
    validate("p", V(2), desc(T.INTEGER, val("one_of", [1, 2])))


def test_one_of_does_not_confuse_true_and_one() -> None:
    with pytest.raises(InvalidValueError):
        validate("p", V(True), desc(T.BOOL, val("one_of", [False])))
    validate("p", V(True), desc(T.BOOL, val("one_of", [True])))


@pytest.mark.parametrize(
    ("validator", "good", "bad", "rule"),
    [
        (val("size_gt", 1), [1, 2], [1], "have a size greater than 1 (it has 1)"),
        (val("size_lt", 2), [1], [1, 2], "have a size less than 2 (it has 2)"),
        (val("fixed_size", 2), [1, 2], [1, 2, 3], "have exactly 2 elements (it has 3)"),
        (Validator("not_empty"), [0], [], "not be empty"),
        (Validator("unique"), [1, 2], [1, 2, 1], "have unique elements (1 repeats)"),
        (val("subset_of", [1, 2]), [2, 2], [1, 3], "only hold elements of [1, 2] (3 is not one)"),
        (val("element_bounds", 0, 9), [0, 9], [0, 10], "have every element within bounds [0, 9] (10 is not)"),
        (val("lower_element_bounds", 0), [0], [-1], "have every element at least 0 (-1 is not)"),
        (val("upper_element_bounds", 0), [0], [1], "have every element at most 0 (1 is not)"),
    ],
)
def test_array_validators(validator: Validator, good: list[int], bad: list[int], rule: str) -> None:
    d = desc(T.INTEGER_ARRAY, validator)
    validate("p", ParameterValue.of(T.INTEGER_ARRAY, good), d)
    with pytest.raises((InvalidValueError, OutOfRangeError)) as info:
        validate("p", ParameterValue.of(T.INTEGER_ARRAY, bad), d)
    shown = ParameterValue.of(T.INTEGER_ARRAY, bad).show()
    assert info.value.message == f"Parameter 'p' with value {shown} must {rule}"


def test_size_validators_count_string_characters() -> None:
    d = desc(T.STRING, val("size_lt", 4), Validator("not_empty"))
    validate("p", V("été"), d)
    with pytest.raises(InvalidValueError, match="not be empty"):
        validate("p", V(""), d)
    with pytest.raises(InvalidValueError, match="less than 4"):
        validate("p", V("abcd"), d)


def test_unique_counts_nan_as_repeating() -> None:
    d = desc(T.DOUBLE_ARRAY, Validator("unique"))
    validate("p", V([math.nan, 1.0]), d)
    with pytest.raises(InvalidValueError, match="nan repeats"):
        validate("p", V([math.nan, math.nan]), d)


def test_element_bounds_refuse_nan() -> None:
    with pytest.raises(OutOfRangeError, match="nan is not"):
        validate("p", V([0.0, math.nan]), desc(T.DOUBLE_ARRAY, val("lower_element_bounds", 0.0)))


def test_validate_refuses_a_wrong_type_unless_dynamic() -> None:
    with pytest.raises(TypeMismatchError, match="expects a double but got string 'x'"):
        validate("p", V("x"), desc(T.DOUBLE))
    validate("p", V("x"), desc(T.DOUBLE, dynamic_typing=True))


def test_a_validator_that_does_not_fit_a_dynamic_value_is_a_type_mismatch() -> None:
    d = desc(T.NOT_SET, val("gt", 0), dynamic_typing=True)
    validate("p", V(1), d)
    with pytest.raises(TypeMismatchError, match="'gt' does not apply to string"):
        validate("p", V("x"), d)


# --- checking validators and descriptors -----------------------------------------------------------


@pytest.mark.parametrize(
    ("ptype", "validator", "words"),
    [
        (T.INTEGER, val("between", 1, 2), "unknown validator 'between'"),
        (T.INTEGER, val("bounds", 1), "takes 2 argument(s), got 1"),
        (T.STRING, val("gt", 1), "'gt' does not apply to a string parameter"),
        (T.INTEGER, Validator("unique"), "'unique' does not apply to a integer parameter"),
        (T.INTEGER, val("bounds", 3, 1), "lower bound 3 is above upper bound 1"),
        (T.INTEGER, val("gt", "x"), "takes finite numbers"),
        (T.DOUBLE, val("gt", math.nan), "takes finite numbers"),
        (T.STRING, val("size_gt", -1), "non-negative integer"),
        (T.STRING, val("one_of", [1, 2]), "takes a list of strings"),
        (T.STRING_ARRAY, val("subset_of", "a"), "takes a list of strings"),
    ],
)
def test_check_validator_names_what_is_wrong(ptype: ParameterType, validator: Validator, words: str) -> None:
    with pytest.raises(InvalidValueError) as info:
        check_validator(ptype, validator)
    assert words in info.value.message


def test_check_validator_accepts_fitting_validators() -> None:
    check_validator(T.DOUBLE, val("one_of", [1, 2]))  # integers compare with doubles
    check_validator(T.STRING_ARRAY, val("subset_of", ["a", "b"]))
    check_validator(T.BYTE_ARRAY, val("element_bounds", 0, 10))
    check_validator(T.NOT_SET, val("gt", 1))  # dynamic: checked against each value


def test_check_descriptor_accepts_ranges_as_rclcpp_does() -> None:
    # Both ranges, a range of the other kind, from > to and a negative step are all accepted
    # by rclcpp (its tests pin their meaning); only a non-finite step is refused.
    check_descriptor(
        desc(T.INTEGER, integer_range=IntegerRange(0, 1), floating_point_range=FloatingPointRange(0, 1))
    )
    check_descriptor(desc(T.STRING, integer_range=IntegerRange(0, 1)))
    check_descriptor(desc(T.DOUBLE, floating_point_range=FloatingPointRange(2.0, 1.0, -0.5)))
    with pytest.raises(InvalidValueError, match="finite step"):
        check_descriptor(desc(T.DOUBLE, floating_point_range=FloatingPointRange(0.0, 1.0, math.nan)))


def test_check_descriptor_refuses_contradictions() -> None:
    with pytest.raises(InvalidValueError, match="Parameter 'p': validator 'gt'"):
        check_descriptor(desc(T.STRING, val("gt", 1)))


@pytest.mark.parametrize(("v", "ok"), [(0, True), (4, True), (10, True), (3, False), (12, False)])
def test_a_negative_integer_step_counts_as_its_magnitude(v: int, ok: bool) -> None:
    d = desc(ParameterType.INTEGER, integer_range=IntegerRange(0, 10, -2))
    check_descriptor(d)
    if ok:
        validate("p", ParameterValue(ParameterType.INTEGER, v), d)
    else:
        with pytest.raises(OutOfRangeError):
            validate("p", ParameterValue(ParameterType.INTEGER, v), d)


def test_a_range_of_the_other_kind_does_not_affect_the_value() -> None:
    d = desc(
        ParameterType.STRING, integer_range=IntegerRange(0, 1), floating_point_range=FloatingPointRange(0, 1)
    )
    check_descriptor(d)
    validate("p", ParameterValue(ParameterType.STRING, "anything"), d)
    with pytest.raises(OutOfRangeError):  # positive control: the same range bounds an integer
        validate(
            "p",
            ParameterValue(ParameterType.INTEGER, 5),
            desc(ParameterType.INTEGER, integer_range=IntegerRange(0, 1)),
        )
