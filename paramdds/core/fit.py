"""A user's value typed against a parameter's descriptor: the one rule of the CLI, the web
console and the ROS 2 bridge.

A value a user gives is typed on its own first (a YAML scalar on the command line, JSON
from a browser, a request's sample): ``1`` is an integer, ``[1, 2]`` an integer array,
and ``[]`` has no element type at all. Three such values mean what the parameter's
declared type says, and :func:`fit_value` gives them that type:

* an empty list (:data:`EMPTY_LIST`) takes the declared array type;
* an integer list for a byte_array parameter is a byte array;
* an integer (an integer list) for a double (a double_array) parameter of a fixed type
  is widened, as the node's table does; ``widen=False`` leaves that to the node, which
  refuses it when it runs with strict types.

The declared type decides the first two even under dynamic typing (a parameter's current
type is the best guess of what an untyped list means). Everything else is returned as it
is: whether it fits is the node's decision, with its own reason
(:func:`paramdds.core.validation.validate`, which a front end may run first).
"""

from __future__ import annotations

from typing import Final

from ..errors import TypeMismatchError
from .descriptors import ParameterDescriptor
from .values import ParameterType, ParameterValue


class EmptyList:
    def __repr__(self) -> str:
        return "EMPTY_LIST"


EMPTY_LIST: Final = EmptyList()
"""An empty list as a user wrote it: no element type of its own until it meets a descriptor."""

_WIDENED = {
    (ParameterType.INTEGER, ParameterType.DOUBLE),
    (ParameterType.INTEGER_ARRAY, ParameterType.DOUBLE_ARRAY),
}


def fit_value(
    name: str,
    value: ParameterValue | EmptyList,
    descriptor: ParameterDescriptor | None,
    *,
    widen: bool = True,
) -> ParameterValue:
    """``value`` for parameter ``name`` declared by ``descriptor`` (None: not declared).

    Raises :class:`~paramdds.errors.TypeMismatchError` for an empty list that no array type
    declares, and for an integer list that is no byte array (an element outside 0..255).
    """
    declared = descriptor.type if descriptor is not None else ParameterType.NOT_SET
    if isinstance(value, EmptyList):
        if declared is ParameterType.NOT_SET:
            raise TypeMismatchError(f"Parameter {name!r}: an empty list has no type of its own")
        if not declared.is_array:
            raise TypeMismatchError(
                f"parameter {name!r} is a {declared.label}; an empty list needs an array"
            )
        return ParameterValue.of(declared, ())
    if value.type is ParameterType.INTEGER_ARRAY and declared is ParameterType.BYTE_ARRAY:
        return ParameterValue.of(ParameterType.BYTE_ARRAY, value.value)
    fixed = descriptor is not None and not descriptor.dynamic_typing
    if widen and fixed and (value.type, declared) in _WIDENED:
        return value.coerce(declared, name=name)
    return value
