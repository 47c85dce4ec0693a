"""Checking a value against its descriptor: type, ROS 2 ranges, validators.

:func:`validate` is the one place a value meets its rules. It raises
:class:`~paramdds.errors.TypeMismatchError` (wrong type),
:class:`~paramdds.errors.OutOfRangeError` (a range, bound or comparison) or
:class:`~paramdds.errors.InvalidValueError` (any other validator), and every
message names the parameter, the value and the rule::

    Parameter 'robot.max_velocity' with value 7.5 must be within bounds [0.0, 5.0]

Ranges (ROS 2 semantics)
    ``integer_range`` applies to integers (and each element of an integer
    array), ``floating_point_range`` to doubles (and each element of a double
    array). A value equal to either bound is always accepted. Otherwise it must
    lie between the bounds and, when ``step`` is not 0, on the grid
    ``from_value + k * step``: for integers ``(v - from) % step == 0``; for doubles
    the nearest grid point must be within a relative tolerance of 1e-6 (rclpy's
    ``PARAM_REL_TOL``); a point within 1e-6 of a step of the grid point also
    passes, so that ``0.0`` on the grid ``-0.3, -0.2, …`` is not refused for a
    rounding error of 5e-17 (a bug rclpy has). Step 0 means continuous. As rclcpp
    pins in its tests: a range of the other kind (a floating-point range on an
    integer or string parameter) does not affect the parameter; with
    ``from_value > to_value`` only the two bounds are valid; a negative step counts
    as its magnitude (the message's definition). Both ranges may be given (a
    dynamically typed parameter meets the one of its current kind).

Validators (generate_parameter_library's, see ``VALIDATOR_ARITY``)
    bounds, lower_bounds, upper_bounds, gt, lt, gt_eq, lt_eq — integers and doubles;
    one_of — bools, integers, doubles and strings;
    size_gt, size_lt, fixed_size, not_empty — strings (length in characters) and arrays;
    unique, subset_of — arrays;
    element_bounds, lower_element_bounds, upper_element_bounds — integer, double
    and byte arrays.
    Bounds are inclusive. NaN and ±inf are legal doubles, but they never pass a
    range or any bound or comparison validator.

:func:`check_validator` checks a validator against a declared type (known kind,
right number and types of arguments, applicable to the type); spec loading and
``ParameterTable.declare`` call it. A custom validator (a name with ``::``) runs the
function registered under its name (:mod:`.custom_validators`); one nobody registered
is not enforced.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from ..errors import InvalidValueError, OutOfRangeError, TypeMismatchError
from .custom_validators import lookup_validator
from .descriptors import VALIDATOR_ARITY, FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from .values import ParameterType, ParameterValue, brief

__all__ = ["PARAM_REL_TOL", "check_descriptor", "check_validator", "validate"]

PARAM_REL_TOL = 1e-6

T = ParameterType
_NUMERIC = frozenset({T.INTEGER, T.DOUBLE})
_SCALARS = frozenset({T.BOOL, T.INTEGER, T.DOUBLE, T.STRING})
_SIZED = frozenset({T.STRING, T.BYTE_ARRAY, T.BOOL_ARRAY, T.INTEGER_ARRAY, T.DOUBLE_ARRAY, T.STRING_ARRAY})
_ARRAYS = frozenset({T.BYTE_ARRAY, T.BOOL_ARRAY, T.INTEGER_ARRAY, T.DOUBLE_ARRAY, T.STRING_ARRAY})
_NUMERIC_ARRAYS = frozenset({T.BYTE_ARRAY, T.INTEGER_ARRAY, T.DOUBLE_ARRAY})

# Which value types each validator applies to.
_APPLIES: dict[str, frozenset[ParameterType]] = {
    "bounds": _NUMERIC,
    "lower_bounds": _NUMERIC,
    "upper_bounds": _NUMERIC,
    "gt": _NUMERIC,
    "lt": _NUMERIC,
    "gt_eq": _NUMERIC,
    "lt_eq": _NUMERIC,
    "one_of": _SCALARS,
    "size_gt": _SIZED,
    "size_lt": _SIZED,
    "fixed_size": _SIZED,
    "not_empty": _SIZED,
    "unique": _ARRAYS,
    "subset_of": _ARRAYS,
    "element_bounds": _NUMERIC_ARRAYS,
    "lower_element_bounds": _NUMERIC_ARRAYS,
    "upper_element_bounds": _NUMERIC_ARRAYS,
}
_SIZE_KINDS = frozenset({"size_gt", "size_lt", "fixed_size"})
_LIST_KINDS = frozenset({"one_of", "subset_of"})


_show = brief


def _number(x: object) -> float | int:
    assert isinstance(x, (int, float)) and not isinstance(x, bool)
    return x


def _finite(x: float | int) -> bool:
    return not isinstance(x, float) or math.isfinite(x)


# --- checking a descriptor ---------------------------------------------------------------------


def check_validator(descriptor_type: ParameterType, validator: Validator) -> None:
    """Raise InvalidValueError unless ``validator`` fits a parameter of ``descriptor_type``.

    With ``NOT_SET`` (a dynamically typed parameter) only the kind and arguments are
    checked; applicability is then checked against each value.
    """
    kind = validator.kind
    if isinstance(kind, str) and "::" in kind:
        for arg in validator.args:
            if not isinstance(arg, ParameterValue):
                raise InvalidValueError(f"validator {kind!r}: its arguments must be parameter values")
        return  # a custom validator: its function (if registered) checks its own arguments
    if kind not in VALIDATOR_ARITY:
        known = ", ".join(VALIDATOR_ARITY)
        raise InvalidValueError(f"unknown validator {kind!r} (known: {known})")
    args = validator.args
    if len(args) != VALIDATOR_ARITY[kind]:
        raise InvalidValueError(
            f"validator {kind!r} takes {VALIDATOR_ARITY[kind]} argument(s), got {len(args)}"
        )
    for arg in args:
        if not isinstance(arg, ParameterValue):
            raise InvalidValueError(f"validator {kind!r}: its arguments must be parameter values")
    applies = _APPLIES[kind]
    if descriptor_type is not T.NOT_SET and descriptor_type not in applies:
        allowed = ", ".join(sorted(t.label for t in applies))
        raise InvalidValueError(
            f"validator {kind!r} does not apply to a {descriptor_type.label} parameter (only to {allowed})"
        )
    if kind in _SIZE_KINDS:
        (arg,) = args
        if arg.type is not T.INTEGER or _number(arg.value) < 0:
            raise InvalidValueError(f"validator {kind!r} takes a non-negative integer, got {_show(arg)}")
    elif kind in _LIST_KINDS:
        (arg,) = args
        element = descriptor_type.element if kind == "subset_of" else descriptor_type
        if not arg.type.is_array or (
            descriptor_type is not T.NOT_SET and not _compatible(element, arg.type.element)
        ):
            wanted = f"a list of {element.label}s" if element is not None else "a list"
            raise InvalidValueError(f"validator {kind!r} takes {wanted}, got {arg.type.label} {_show(arg)}")
    elif args:
        for arg in args:
            if arg.type not in _NUMERIC or not _finite(_number(arg.value)):
                raise InvalidValueError(f"validator {kind!r} takes finite numbers, got {_show(arg)}")
        if kind.endswith("bounds") and len(args) == 2 and _number(args[0].value) > _number(args[1].value):
            raise InvalidValueError(
                f"validator {kind!r}: lower bound {_show(args[0])} is above upper bound {_show(args[1])}"
            )


def _compatible(element: ParameterType | None, arg_element: ParameterType | None) -> bool:
    if element is None or arg_element is None:
        return False
    return element is arg_element or {element, arg_element} == _NUMERIC


def check_descriptor(descriptor: ParameterDescriptor) -> None:
    """Raise InvalidValueError when a descriptor contradicts itself (ranges, validators)."""
    ptype = descriptor.type
    name = descriptor.name
    fr = descriptor.floating_point_range
    # As in rclcpp: a range applies only to values of its kind (one of the wrong kind is
    # ignored), from_value > to_value leaves only the two bounds valid, and a negative step
    # counts as its magnitude. Only a step that is not a finite number is refused.
    if fr is not None and not (
        math.isfinite(fr.step) and not math.isnan(fr.from_value) and not math.isnan(fr.to_value)
    ):
        raise InvalidValueError(
            f"Parameter {name!r}: floating_point_range [{fr.from_value}, {fr.to_value}] step {fr.step} "
            "needs numbers for its bounds and a finite step"
        )
    for validator in descriptor.validators:
        try:
            check_validator(ptype, validator)
        except InvalidValueError as exc:
            raise InvalidValueError(f"Parameter {name!r}: {exc.message}") from None


# --- checking a value --------------------------------------------------------------------------


def validate(name: str, value: ParameterValue, descriptor: ParameterDescriptor) -> None:
    """Raise unless ``value`` is acceptable for a parameter ``name`` described by ``descriptor``.

    The value must already have the declared type (the table widens integers first);
    a dynamically typed parameter accepts any type.
    """
    dtype = descriptor.type
    if not descriptor.dynamic_typing and dtype is not T.NOT_SET and value.type is not dtype:
        raise TypeMismatchError(
            f"Parameter {name!r} expects a {dtype.label} but got {value.type.label} {_show(value)}"
        )
    if value.type is T.NOT_SET:
        return
    if descriptor.integer_range is not None:
        _check_integer_range(name, value, descriptor.integer_range)
    if descriptor.floating_point_range is not None:
        _check_float_range(name, value, descriptor.floating_point_range)
    for validator in descriptor.validators:
        _check(name, value, validator)


def _elements(value: ParameterValue, scalar: ParameterType) -> tuple[object, ...] | None:
    """The numbers a range applies to: the value itself or its elements; None when not applicable."""
    if value.type is scalar:
        return (value.value,)
    if value.type.element is scalar and value.type is not T.BYTE_ARRAY:
        assert isinstance(value.value, tuple)
        return value.value
    return None


def _range_error(name: str, value: ParameterValue, lo: object, hi: object, step: object) -> OutOfRangeError:
    grid = f" in steps of {step}" if step else ""
    return OutOfRangeError(f"Parameter {name!r} with value {_show(value)} must be within [{lo}, {hi}]{grid}")


def _check_integer_range(name: str, value: ParameterValue, r: IntegerRange) -> None:
    numbers = _elements(value, T.INTEGER)
    if numbers is None:
        return
    for x in numbers:
        v = _number(x)
        if v in (r.from_value, r.to_value):
            continue
        if not r.from_value <= v <= r.to_value or (r.step and (v - r.from_value) % r.step):
            raise _range_error(name, value, r.from_value, r.to_value, r.step)


def on_float_grid(v: float, lo: float, step: float) -> bool:
    """True when ``v`` is a grid point ``lo + k * step`` up to the tolerance described above."""
    k = round((v - lo) / step)
    nearest = lo + k * step
    return math.isclose(v, nearest, rel_tol=PARAM_REL_TOL) or abs(v - nearest) <= PARAM_REL_TOL * abs(step)


def _check_float_range(name: str, value: ParameterValue, r: FloatingPointRange) -> None:
    numbers = _elements(value, T.DOUBLE)
    if numbers is None:
        return
    lo, hi, step = r.from_value, r.to_value, r.step
    for x in numbers:
        v = float(_number(x))
        ok = math.isfinite(v) and (
            math.isclose(v, lo, rel_tol=PARAM_REL_TOL)
            or math.isclose(v, hi, rel_tol=PARAM_REL_TOL)
            or (lo <= v <= hi and (step == 0 or on_float_grid(v, lo, step)))
        )
        if not ok:
            raise _range_error(name, value, lo, hi, step)


def _check(name: str, value: ParameterValue, validator: Validator) -> None:
    kind = validator.kind
    if "::" in kind:
        _check_custom(name, value, validator)
        return
    if kind not in _CHECKS:
        raise InvalidValueError(f"Parameter {name!r} has an unknown validator {kind!r}")
    if value.type not in _APPLIES[kind]:
        raise TypeMismatchError(
            f"Parameter {name!r}: validator {kind!r} does not apply to {value.type.label} {_show(value)}"
        )
    args = [a.value for a in validator.args]
    rule = _CHECKS[kind](value, args)
    if rule is not None:
        error = OutOfRangeError if kind in _RANGE_KINDS else InvalidValueError
        raise error(f"Parameter {name!r} with value {_show(value)} must {rule}")


def _check_custom(name: str, value: ParameterValue, validator: Validator) -> None:
    """A registered ``ns::fn`` validator; one nobody registered is not enforced (see custom_validators)."""
    check = lookup_validator(validator.kind)
    if check is None:
        return
    try:
        rule = check(value, validator.args)
    except Exception as exc:  # a user's function: its failure refuses the value, never the server
        rule = f"pass {validator.kind} (which failed: {type(exc).__name__}: {exc})"
    if rule is not None:
        raise InvalidValueError(f"Parameter {name!r} with value {_show(value)} must {rule}")


def _show_arg(x: object) -> str:
    return ParameterValue.from_python(x).show()


def _bounds(value: ParameterValue, args: Sequence[object]) -> str | None:
    lo, hi = _number(args[0]), _number(args[1])
    v = _number(value.value)
    return None if _finite(v) and lo <= v <= hi else f"be within bounds [{_show_arg(lo)}, {_show_arg(hi)}]"


def _one_bound(lower: bool) -> Callable[[ParameterValue, Sequence[object]], str | None]:
    def check(value: ParameterValue, args: Sequence[object]) -> str | None:
        b = _number(args[0])
        v = _number(value.value)
        ok = _finite(v) and (v >= b if lower else v <= b)
        return None if ok else f"be {'at least' if lower else 'at most'} {_show_arg(b)}"

    return check


def _comparison(kind: str) -> Callable[[ParameterValue, Sequence[object]], str | None]:
    ops: dict[str, tuple[Callable[[float | int, float | int], bool], str]] = {
        "gt": (lambda v, b: v > b, "be greater than"),
        "lt": (lambda v, b: v < b, "be less than"),
        "gt_eq": (lambda v, b: v >= b, "be greater than or equal to"),
        "lt_eq": (lambda v, b: v <= b, "be less than or equal to"),
    }
    op, text = ops[kind]

    def check(value: ParameterValue, args: Sequence[object]) -> str | None:
        b = _number(args[0])
        v = _number(value.value)
        return None if _finite(v) and op(v, b) else f"{text} {_show_arg(b)}"

    return check


def _size(value: ParameterValue) -> int:
    assert isinstance(value.value, (str, bytes, tuple))
    return len(value.value)


def _size_gt(value: ParameterValue, args: Sequence[object]) -> str | None:
    n = _number(args[0])
    return None if _size(value) > n else f"have a size greater than {n} (it has {_size(value)})"


def _size_lt(value: ParameterValue, args: Sequence[object]) -> str | None:
    n = _number(args[0])
    return None if _size(value) < n else f"have a size less than {n} (it has {_size(value)})"


def _fixed_size(value: ParameterValue, args: Sequence[object]) -> str | None:
    n = _number(args[0])
    return None if _size(value) == n else f"have exactly {n} elements (it has {_size(value)})"


def _not_empty(value: ParameterValue, args: Sequence[object]) -> str | None:
    return None if _size(value) > 0 else "not be empty"


def _as_tuple(x: object) -> tuple[object, ...]:
    if isinstance(x, bytes):
        return tuple(x)
    assert isinstance(x, tuple)
    return x


def _one_of(value: ParameterValue, args: Sequence[object]) -> str | None:
    choices = _as_tuple(args[0])
    v = value.value
    ok = any(_equal(v, c) for c in choices)
    return None if ok else f"be one of {_show_list(choices)}"


def _equal(a: object, b: object) -> bool:
    # bool is never an integer: True must not match 1.
    return isinstance(a, bool) == isinstance(b, bool) and a == b


def _show_list(items: tuple[object, ...]) -> str:
    return "[" + ", ".join(_show_arg(x) for x in items) + "]"


def _unique(value: ParameterValue, args: Sequence[object]) -> str | None:
    seen: set[object] = set()
    for x in _as_tuple(value.value):
        key = "nan" if isinstance(x, float) and math.isnan(x) else x  # NaN repeats NaN
        if key in seen:
            return f"have unique elements ({_show_arg(x)} repeats)"
        seen.add(key)
    return None


def _subset_of(value: ParameterValue, args: Sequence[object]) -> str | None:
    allowed = _as_tuple(args[0])
    for x in _as_tuple(value.value):
        if not any(_equal(x, c) for c in allowed):
            return f"only hold elements of {_show_list(allowed)} ({_show_arg(x)} is not one)"
    return None


def _element_bounds(kind: str) -> Callable[[ParameterValue, Sequence[object]], str | None]:
    def check(value: ParameterValue, args: Sequence[object]) -> str | None:
        nums = [_number(a) for a in args]
        if kind == "element_bounds":
            lo, hi = nums[0], nums[1]
            rule = f"have every element within bounds [{_show_arg(lo)}, {_show_arg(hi)}]"
        elif kind == "lower_element_bounds":
            lo, hi, rule = nums[0], math.inf, f"have every element at least {_show_arg(nums[0])}"
        else:
            lo, hi, rule = -math.inf, nums[0], f"have every element at most {_show_arg(nums[0])}"
        for x in _as_tuple(value.value):
            v = _number(x)
            if not (_finite(v) and lo <= v <= hi):
                return f"{rule} ({_show_arg(v)} is not)"
        return None

    return check


_CHECKS: dict[str, Callable[[ParameterValue, Sequence[object]], str | None]] = {
    "bounds": _bounds,
    "lower_bounds": _one_bound(lower=True),
    "upper_bounds": _one_bound(lower=False),
    "gt": _comparison("gt"),
    "lt": _comparison("lt"),
    "gt_eq": _comparison("gt_eq"),
    "lt_eq": _comparison("lt_eq"),
    "one_of": _one_of,
    "size_gt": _size_gt,
    "size_lt": _size_lt,
    "fixed_size": _fixed_size,
    "not_empty": _not_empty,
    "unique": _unique,
    "subset_of": _subset_of,
    "element_bounds": _element_bounds("element_bounds"),
    "lower_element_bounds": _element_bounds("lower_element_bounds"),
    "upper_element_bounds": _element_bounds("upper_element_bounds"),
}
_RANGE_KINDS = frozenset(
    {
        "bounds",
        "lower_bounds",
        "upper_bounds",
        "gt",
        "lt",
        "gt_eq",
        "lt_eq",
        "element_bounds",
        "lower_element_bounds",
        "upper_element_bounds",
    }
)
assert set(_CHECKS) == set(VALIDATOR_ARITY) == set(_APPLIES)
