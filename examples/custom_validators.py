"""Custom spec validators for ``paramdds server --validators custom_validators`` (run from examples/).

A spec names them as generate_parameter_library does: ``robot::multiple_of<>: [5]``.
Each function gets the value and the validator's arguments (ParameterValue objects) and
returns None when the value passes, or the rule it breaks, phrased to follow "must".
"""

from __future__ import annotations

from paramdds.core import ParameterType, ParameterValue, register_validator


def multiple_of(value: ParameterValue, args: tuple[ParameterValue, ...]) -> str | None:
    """An integer that is a multiple of ``args[0]``."""
    (step,) = args
    if value.type is not ParameterType.INTEGER or step.type is not ParameterType.INTEGER:
        return "be an integer, with an integer step"
    assert isinstance(value.value, int) and isinstance(step.value, int)
    return None if step.value and value.value % step.value == 0 else f"be a multiple of {step.value}"


register_validator("robot::multiple_of", multiple_of, replace=True)
