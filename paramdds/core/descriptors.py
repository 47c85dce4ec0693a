"""Parameter descriptors: what a node promises about one parameter.

A descriptor carries ROS 2's fields (type, description, additional_constraints,
read_only, dynamic_typing, one integer or floating-point range) plus the
validators of generate_parameter_library that ROS 2 lacks. The checking logic
lives in :mod:`paramdds.core.validation`; this module only holds the data.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .values import ParameterType, ParameterValue

# The validators we support, by their generate_parameter_library name (without
# the ``<>``) and the number of arguments each takes.
VALIDATOR_ARITY: dict[str, int] = {
    "bounds": 2,  # [lo, hi] inclusive
    "lower_bounds": 1,
    "upper_bounds": 1,
    "gt": 1,
    "lt": 1,
    "gt_eq": 1,
    "lt_eq": 1,
    "one_of": 1,  # [[a, b, c]]
    "size_gt": 1,
    "size_lt": 1,
    "fixed_size": 1,
    "not_empty": 0,
    "unique": 0,
    "subset_of": 1,  # [[a, b, c]]
    "element_bounds": 2,
    "lower_element_bounds": 1,
    "upper_element_bounds": 1,
}


@dataclass(frozen=True, slots=True)
class IntegerRange:
    """An inclusive range of integers, and a step from ``from_value`` (0: any value in range)."""

    from_value: int
    to_value: int
    step: int = 0


@dataclass(frozen=True, slots=True)
class FloatingPointRange:
    """An inclusive range of doubles, and a step from ``from_value`` (0.0: any value in range)."""

    from_value: float
    to_value: float
    step: float = 0.0


@dataclass(frozen=True, slots=True)
class Validator:
    """One validator: ``Validator("bounds", (ParameterValue(DOUBLE, 0.0), ParameterValue(DOUBLE, 5.0)))``."""

    kind: str
    args: tuple[ParameterValue, ...] = ()


@dataclass(frozen=True, slots=True)
class ParameterDescriptor:
    """What a parameter is and what it accepts (rcl_interfaces' ParameterDescriptor)."""

    name: str
    type: ParameterType = ParameterType.NOT_SET
    description: str = ""
    additional_constraints: str = ""
    read_only: bool = False
    dynamic_typing: bool = False
    integer_range: IntegerRange | None = None
    floating_point_range: FloatingPointRange | None = None
    validators: tuple[Validator, ...] = field(default_factory=tuple)
