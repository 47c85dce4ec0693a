"""The scalar resolver mirrors rcl_yaml_param_parser, not PyYAML's YAML 1.1 rules."""

from __future__ import annotations

import ctypes
import ctypes.util
import math
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.errors import ErrorCode, InvalidValueError
from paramdds.formats.ros import load_ros_params_str
from paramdds.formats.scalar import parse_cli_value, resolve_plain


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        # bools: exact spellings, including the YAML 1.1 words rcl keeps
        ("true", PV(T.BOOL, True)),
        ("True", PV(T.BOOL, True)),
        ("TRUE", PV(T.BOOL, True)),
        ("yes", PV(T.BOOL, True)),
        ("on", PV(T.BOOL, True)),
        ("Y", PV(T.BOOL, True)),
        ("false", PV(T.BOOL, False)),
        ("Off", PV(T.BOOL, False)),
        ("n", PV(T.BOOL, False)),
        ("tRUE", PV(T.STRING, "tRUE")),
        # integers: strtoll base 0
        ("42", PV(T.INTEGER, 42)),
        ("-7", PV(T.INTEGER, -7)),
        ("+7", PV(T.INTEGER, 7)),
        ("0x1A", PV(T.INTEGER, 26)),
        ("010", PV(T.INTEGER, 8)),
        ("9223372036854775807", PV(T.INTEGER, 2**63 - 1)),
        # doubles: strtod
        ("1.5", PV(T.DOUBLE, 1.5)),
        ("1e3", PV(T.DOUBLE, 1000.0)),
        (".5", PV(T.DOUBLE, 0.5)),
        ("5.", PV(T.DOUBLE, 5.0)),
        ("08", PV(T.DOUBLE, 8.0)),
        ("0x1.8p1", PV(T.DOUBLE, 3.0)),
        ("9223372036854775808", PV(T.DOUBLE, 9.223372036854775808e18)),
        (".inf", PV(T.DOUBLE, math.inf)),
        ("-.Inf", PV(T.DOUBLE, -math.inf)),
        ("Infinity", PV(T.DOUBLE, math.inf)),
        # strings
        ("1:20", PV(T.STRING, "1:20")),
        ("1_000", PV(T.STRING, "1_000")),
        ("0b101", PV(T.STRING, "0b101")),
        ("~", PV(T.STRING, "~")),
        ("null", PV(T.STRING, "null")),
        ("-.nan", PV(T.STRING, "-.nan")),
        ("1e999", PV(T.STRING, "1e999")),
        ("2024-01-01", PV(T.STRING, "2024-01-01")),
        ("abc", PV(T.STRING, "abc")),
    ],
)
def test_plain_scalars_are_typed_as_rcl_types_them(text: str, expected: PV) -> None:
    assert resolve_plain(text) == expected


@pytest.mark.parametrize("text", [".nan", ".NaN", ".NAN", "nan", "NAN", "nan(1)"])
def test_nan_spellings_are_doubles(text: str) -> None:
    value = resolve_plain(text)
    assert value.type is T.DOUBLE and math.isnan(value.value)  # type: ignore[arg-type]


def _libc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux"):
        return None
    name = ctypes.util.find_library("c")
    return ctypes.CDLL(name, use_errno=True) if name else None


_LIBC = _libc()


def _rcl_reference(text: str) -> tuple[str, object]:
    """rcl's get_value() int/double steps, run with the real C library."""
    assert _LIBC is not None
    strtoll, strtod = _LIBC.strtoll, _LIBC.strtod
    strtoll.restype, strtod.restype = ctypes.c_longlong, ctypes.c_double
    strtoll.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p), ctypes.c_int]
    strtod.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p)]
    raw = text.encode()
    buf = ctypes.create_string_buffer(raw)
    end = ctypes.c_char_p()
    for kind, call in (
        ("int", lambda: strtoll(buf, ctypes.byref(end), 0)),
        ("double", lambda: strtod(buf, ctypes.byref(end))),
    ):
        ctypes.set_errno(0)
        v = call()
        consumed = (ctypes.cast(end, ctypes.c_void_p).value or 0) - ctypes.addressof(buf)
        if ctypes.get_errno() == 0 and consumed == len(raw):
            return kind, v
    return "string", text


@pytest.mark.skipif(_LIBC is None, reason="needs the C library of a Linux system")
@settings(max_examples=3000, deadline=None)
@given(st.text(alphabet="0123456789xXabcdefABCDEF+-.eEpPinftyINFTY_:", min_size=1, max_size=8))
def test_numbers_match_the_c_library_rcl_uses(text: str) -> None:
    if text in {"y", "Y", "n", "N"} or text.lstrip("+-").lower() in {".inf", ".nan"}:
        return  # bool words and rcl's own YAML inf/nan forms are covered above
    kind, ref = _rcl_reference(text)
    got = resolve_plain(text)
    if kind == "string" and got.type is T.DOUBLE and 0 < abs(got.value) < sys.float_info.min:  # type: ignore[arg-type]
        return  # documented deviation: subnormals stay doubles so dumps round-trip
    assert got.type.label == {"int": "integer", "double": "double", "string": "string"}[kind]
    if kind == "double" and math.isnan(ref):  # type: ignore[arg-type]
        assert math.isnan(got.value)  # type: ignore[arg-type]
    elif kind != "string":
        assert got.value == ref


def test_quoted_and_str_tagged_scalars_stay_strings() -> None:
    values = load_ros_params_str(
        'n:\n  ros__parameters:\n    a: \'5\'\n    b: "true"\n    c: !!str 1.5\n    d: ""\n', "n"
    )
    assert values == {
        "a": PV(T.STRING, "5"),
        "b": PV(T.STRING, "true"),
        "c": PV(T.STRING, "1.5"),
        "d": PV(T.STRING, ""),
    }


def test_block_scalars_are_typed_by_content_like_rcl() -> None:
    values = load_ros_params_str("n:\n  ros__parameters:\n    a: |-\n      5\n    b: |\n      text\n", "n")
    assert values == {"a": PV(T.INTEGER, 5), "b": PV(T.STRING, "text\n")}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("1", PV(T.INTEGER, 1)),
        ("1.5", PV(T.DOUBLE, 1.5)),
        ("true", PV(T.BOOL, True)),
        ("[1, 2]", PV(T.INTEGER_ARRAY, (1, 2))),
        ("[1.0, 2.5]", PV(T.DOUBLE_ARRAY, (1.0, 2.5))),
        ('["a", b]', PV(T.STRING_ARRAY, ("a", "b"))),
        ('"on"', PV(T.STRING, "on")),
        ("abc", PV(T.STRING, "abc")),
        ("hello world", PV(T.STRING, "hello world")),
        ("1:20", PV(T.STRING, "1:20")),
        ("!double_array []", PV(T.DOUBLE_ARRAY, ())),
        ("!byte_array [0, 255]", PV(T.BYTE_ARRAY, b"\x00\xff")),
        ("!not_set", PV(T.NOT_SET, None)),
    ],
)
def test_cli_values_use_the_same_resolver(text: str, expected: PV) -> None:
    assert parse_cli_value(text) == expected


def test_cli_value_with_an_expected_type() -> None:
    assert parse_cli_value("5", T.DOUBLE) == PV(T.DOUBLE, 5.0)
    assert parse_cli_value("5", T.STRING) == PV(T.STRING, "5")
    assert parse_cli_value("[]", T.STRING_ARRAY) == PV(T.STRING_ARRAY, ())
    with pytest.raises(InvalidValueError, match="expected an integer"):
        parse_cli_value("1.5", T.INTEGER)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty value"),
        ("[1, 2.5]", "one type.*1.0, not 1"),
        ("[]", "empty list has no type"),
        ("a: b", "is a map.*quote it"),
        ("[1, [2]]", "only single values"),
        ("'unterminated", "cannot read value"),
        ("!byte_array [256]", "0..255"),
    ],
)
def test_bad_cli_values_are_refused_clearly(text: str, match: str) -> None:
    with pytest.raises(InvalidValueError, match=match) as info:
        parse_cli_value(text)
    assert info.value.code is ErrorCode.INVALID_VALUE
