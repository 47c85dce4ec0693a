"""A user's value typed against a descriptor: the one rule of the CLI, the web console and the bridge."""

from __future__ import annotations

import pytest

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.fit import EMPTY_LIST, fit_value
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import TypeMismatchError

PV = ParameterValue
T = ParameterType


def _d(ptype: ParameterType, dynamic: bool = False) -> ParameterDescriptor:
    return ParameterDescriptor("x", ptype, dynamic_typing=dynamic)


def test_an_empty_list_takes_the_declared_array_type_even_under_dynamic_typing() -> None:
    assert fit_value("x", EMPTY_LIST, _d(T.DOUBLE_ARRAY)).same_as(PV.of(T.DOUBLE_ARRAY, []))
    assert fit_value("x", EMPTY_LIST, _d(T.STRING_ARRAY, dynamic=True)).same_as(PV.of(T.STRING_ARRAY, []))
    with pytest.raises(TypeMismatchError, match="needs an array"):
        fit_value("x", EMPTY_LIST, _d(T.DOUBLE))
    with pytest.raises(TypeMismatchError, match="no type of its own"):
        fit_value("x", EMPTY_LIST, None)


def test_an_integer_list_is_a_byte_array_for_a_byte_array_parameter() -> None:
    ints = PV.of(T.INTEGER_ARRAY, [1, 255])
    assert fit_value("x", ints, _d(T.BYTE_ARRAY)).same_as(PV(T.BYTE_ARRAY, b"\x01\xff"))
    assert fit_value("x", ints, _d(T.INTEGER_ARRAY)) is ints
    with pytest.raises(TypeMismatchError):
        fit_value("x", PV.of(T.INTEGER_ARRAY, [1, 256]), _d(T.BYTE_ARRAY))


def test_integers_widen_for_a_fixed_double_unless_the_node_decides() -> None:
    assert fit_value("x", PV(T.INTEGER, 2), _d(T.DOUBLE)).same_as(PV(T.DOUBLE, 2.0))
    doubles = fit_value("x", PV.of(T.INTEGER_ARRAY, [1]), _d(T.DOUBLE_ARRAY))
    assert doubles.same_as(PV.of(T.DOUBLE_ARRAY, [1.0]))
    assert fit_value("x", PV(T.INTEGER, 2), _d(T.DOUBLE), widen=False).type is T.INTEGER
    assert fit_value("x", PV(T.INTEGER, 2), _d(T.DOUBLE, dynamic=True)).type is T.INTEGER
    assert fit_value("x", PV(T.INTEGER, 2), None).type is T.INTEGER


def test_everything_else_is_left_to_the_node() -> None:
    text = PV(T.STRING, "fast")
    assert fit_value("x", text, _d(T.DOUBLE)) is text
    assert fit_value("x", PV(T.DOUBLE, 1.5), _d(T.INTEGER)).type is T.DOUBLE
