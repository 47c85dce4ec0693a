"""ParameterValue: the ten types, construction, widening, and only our own errors."""

import math
from enum import IntEnum

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.limits import MAX_VALUE_BYTES, check_value, value_size
from paramdds.core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from paramdds.errors import InvalidValueError, ParamddsError, TooLargeError, TypeMismatchError

T = ParameterType

ints = st.integers(min_value=INT64_MIN, max_value=INT64_MAX)
floats = st.floats(allow_nan=True, allow_infinity=True)
# Text that can cross the wire: no lone surrogates.
texts = st.text(alphabet=st.characters(blacklist_categories=("Cs",)))

SCALARS = {T.BOOL: st.booleans(), T.INTEGER: ints, T.DOUBLE: floats, T.STRING: texts}


@st.composite
def typed_values(draw: st.DrawFn) -> tuple[ParameterType, object]:
    ptype = draw(st.sampled_from([t for t in T if t is not T.NOT_SET]))
    if ptype is T.BYTE_ARRAY:
        return ptype, draw(st.binary(max_size=20))
    element = ptype.element
    if element is None:
        return ptype, draw(SCALARS[ptype])
    return ptype, draw(st.lists(SCALARS[element], max_size=8))


@given(typed_values())
def test_of_then_to_python_round_trips(tv: tuple[ParameterType, object]) -> None:
    ptype, raw = tv
    value = ParameterValue.of(ptype, raw)
    assert value.type is ptype
    again = ParameterValue.of(ptype, value.to_python())
    assert again.same_as(value)


@given(typed_values())
def test_from_python_infers_the_type_of_non_empty_values(tv: tuple[ParameterType, object]) -> None:
    ptype, raw = tv
    if isinstance(raw, list) and not raw:
        with pytest.raises(TypeMismatchError, match="empty list"):
            ParameterValue.from_python(raw)
        return
    value = ParameterValue.from_python(raw)
    assert value.type is ptype
    assert value.same_as(ParameterValue.of(ptype, raw))


def test_bool_is_never_an_integer() -> None:
    assert ParameterValue.from_python(True).type is T.BOOL
    with pytest.raises(TypeMismatchError):
        ParameterValue.of(T.INTEGER, True)
    with pytest.raises(TypeMismatchError):
        ParameterValue.of(T.INTEGER_ARRAY, [1, True])
    with pytest.raises(TypeMismatchError):
        ParameterValue.from_python(True).coerce(T.INTEGER)


def test_arrays_are_homogeneous() -> None:
    with pytest.raises(TypeMismatchError, match="write every element as a double"):
        ParameterValue.from_python([1, 2.5])
    with pytest.raises(TypeMismatchError):
        ParameterValue.from_python(["a", 1])
    with pytest.raises(TypeMismatchError):
        ParameterValue.from_python([[1], [2]])


def test_integers_outside_int64_are_rejected() -> None:
    assert ParameterValue.from_python(INT64_MAX).value == INT64_MAX
    assert ParameterValue.from_python(INT64_MIN).value == INT64_MIN
    with pytest.raises(InvalidValueError, match="64 bits"):
        ParameterValue.from_python(INT64_MAX + 1)
    with pytest.raises(InvalidValueError, match="64 bits"):
        ParameterValue.from_python([0, INT64_MIN - 1])
    with pytest.raises(InvalidValueError, match="bits"):
        ParameterValue.from_python(10**5000)  # too long even to print


def test_integer_widens_to_the_exact_double() -> None:
    widened = ParameterValue.from_python(50).coerce(T.DOUBLE)
    assert widened == ParameterValue(T.DOUBLE, 50.0)
    assert isinstance(widened.value, float)
    arr = ParameterValue.from_python([1, 2]).coerce(T.DOUBLE_ARRAY)
    assert arr == ParameterValue(T.DOUBLE_ARRAY, (1.0, 2.0))


def test_strict_widening_tells_how_to_write_a_double() -> None:
    with pytest.raises(TypeMismatchError) as info:
        ParameterValue.from_python(50).coerce(T.DOUBLE, strict=True, name="speed")
    assert "'speed'" in info.value.message
    assert "50.0" in info.value.message


def test_an_integer_without_an_exact_double_is_refused() -> None:
    with pytest.raises(TypeMismatchError, match="no exact double"):
        ParameterValue.from_python(2**53 + 1).coerce(T.DOUBLE)


def test_a_double_is_never_narrowed() -> None:
    with pytest.raises(TypeMismatchError, match="expects a integer"):
        ParameterValue.from_python(2.0).coerce(T.INTEGER)


def test_nan_and_inf_are_legal_doubles() -> None:
    assert math.isnan(ParameterValue.from_python(math.nan).value)  # type: ignore[arg-type]
    assert ParameterValue.from_python(-math.inf).value == -math.inf
    nan = ParameterValue.from_python(math.nan)
    assert nan.same_as(ParameterValue.from_python(math.nan))
    assert not nan.same_as(ParameterValue.from_python(1.0))


def test_subclasses_become_plain_values() -> None:
    class Level(IntEnum):
        HIGH = 3

    value = ParameterValue.from_python(Level.HIGH)
    assert value.type is T.INTEGER
    assert type(value.value) is int


def test_strings_that_cannot_be_encoded_are_refused() -> None:
    with pytest.raises(InvalidValueError, match="surrogate"):
        ParameterValue.from_python("\ud800")


def test_unknown_types_raise_our_error() -> None:
    with pytest.raises(InvalidValueError, match="unknown parameter type"):
        ParameterValue.of(42, 1)  # type: ignore[arg-type]
    with pytest.raises(InvalidValueError, match="known: bool"):
        ParameterType.from_label("float")
    assert ParameterType.from_label(" Double_Array ") is T.DOUBLE_ARRAY


def test_show_is_what_a_user_would_write() -> None:
    assert ParameterValue.from_python(True).show() == "true"
    assert ParameterValue.from_python([1.5, 2.0]).show() == "[1.5, 2.0]"
    assert ParameterValue.from_python("a").show() == "'a'"
    assert ParameterValue.from_python(b"\x01\x02").show() == "[1, 2]"
    assert NOT_SET.show() == "not_set"


class _BadRepr:
    def __repr__(self) -> str:
        raise RuntimeError("no repr")


anything = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats()
    | st.text()
    | st.binary()
    | st.complex_numbers()
    | st.builds(object)
    | st.builds(_BadRepr)
    | st.just(T.BOOL),
    lambda inner: (
        st.lists(inner, max_size=4) | st.tuples(inner) | st.dictionaries(st.text(), inner, max_size=2)
    ),
    max_leaves=10,
)


@given(anything)
def test_from_python_raises_only_our_errors(obj: object) -> None:
    try:
        value = ParameterValue.from_python(obj)
    except ParamddsError as exc:
        assert exc.message
        return
    assert isinstance(value, ParameterValue)
    assert ParameterValue.of(value.type, value.to_python()).same_as(value)


@given(st.sampled_from(list(T)), anything)
def test_of_raises_only_our_errors(ptype: ParameterType, obj: object) -> None:
    try:
        value = ParameterValue.of(ptype, obj)
    except ParamddsError:
        return
    assert value.type is ptype


def test_value_size_counts_encoded_bytes() -> None:
    assert value_size(ParameterValue.from_python("héllo")) == 6
    assert value_size(ParameterValue.from_python([1, 2, 3])) == 24
    assert value_size(ParameterValue.from_python([True, False])) == 2
    assert value_size(ParameterValue.from_python(b"abcd")) == 4
    assert value_size(ParameterValue.from_python(["ab", "é"])) == (2 + 1) + (2 + 1)
    assert value_size(ParameterValue.from_python(1.0)) == 8


def test_check_value_names_the_parameter_and_the_limit() -> None:
    check_value("ok", ParameterValue.from_python("x" * MAX_VALUE_BYTES))
    with pytest.raises(TooLargeError) as info:
        check_value("blob", ParameterValue.from_python(b"x" * (MAX_VALUE_BYTES + 1)))
    assert "'blob'" in info.value.message
    assert str(MAX_VALUE_BYTES) in info.value.message


def test_same_as_is_exact_nan_equals_nan_and_a_sign_is_a_change() -> None:
    """What a round trip must keep, and what the web console's load counts as no change."""
    d = ParameterType.DOUBLE
    assert ParameterValue.of(d, math.nan).same_as(ParameterValue.of(d, math.nan))
    assert not ParameterValue.of(d, -0.0).same_as(ParameterValue.of(d, 0.0))
    arrays = ParameterType.DOUBLE_ARRAY
    assert not ParameterValue.of(arrays, [1.0, -0.0]).same_as(ParameterValue.of(arrays, [1.0, 0.0]))
    assert ParameterValue.of(arrays, [math.nan]).same_as(ParameterValue.of(arrays, [math.nan]))
    assert not ParameterValue.of(ParameterType.INTEGER, 1).same_as(ParameterValue.of(d, 1.0))
