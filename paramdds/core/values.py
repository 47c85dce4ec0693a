"""Parameter types and values: the ten ROS 2 types, checked on construction.

A :class:`ParameterValue` is immutable and always well formed: its Python value
matches its type exactly (arrays are tuples, byte arrays are ``bytes``, integers
fit in int64, a ``bool`` is never an integer). Widening an integer to a double is
the only implicit conversion and happens in :meth:`ParameterValue.coerce`, never
on construction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from ..errors import InvalidValueError, TypeMismatchError

INT64_MIN = -(2**63)
INT64_MAX = 2**63 - 1

Scalar = bool | int | float | str
PyValue = (
    None
    | bool
    | int
    | float
    | str
    | bytes
    | tuple[bool, ...]
    | tuple[int, ...]
    | tuple[float, ...]
    | tuple[str, ...]
)


class ParameterType(IntEnum):
    """The ROS 2 parameter types, with the same numbers as rcl_interfaces."""

    NOT_SET = 0
    BOOL = 1
    INTEGER = 2
    DOUBLE = 3
    STRING = 4
    BYTE_ARRAY = 5
    BOOL_ARRAY = 6
    INTEGER_ARRAY = 7
    DOUBLE_ARRAY = 8
    STRING_ARRAY = 9

    @property
    def label(self) -> str:
        """The name used in files and on the command line: ``double_array``."""
        return self.name.lower()

    @classmethod
    def from_label(cls, label: str) -> ParameterType:
        try:
            return cls[str(label).strip().upper()]
        except KeyError:
            known = ", ".join(t.label for t in cls if t is not cls.NOT_SET)
            raise InvalidValueError(f"unknown parameter type {label!r} (known: {known})") from None

    @property
    def is_array(self) -> bool:
        return self >= ParameterType.BYTE_ARRAY

    @property
    def element(self) -> ParameterType | None:
        """The scalar type of an array's elements (BYTE_ARRAY has INTEGER elements)."""
        return _ELEMENT.get(self)


_ELEMENT = {
    ParameterType.BYTE_ARRAY: ParameterType.INTEGER,
    ParameterType.BOOL_ARRAY: ParameterType.BOOL,
    ParameterType.INTEGER_ARRAY: ParameterType.INTEGER,
    ParameterType.DOUBLE_ARRAY: ParameterType.DOUBLE,
    ParameterType.STRING_ARRAY: ParameterType.STRING,
}
_ARRAY_OF = {
    ParameterType.BOOL: ParameterType.BOOL_ARRAY,
    ParameterType.INTEGER: ParameterType.INTEGER_ARRAY,
    ParameterType.DOUBLE: ParameterType.DOUBLE_ARRAY,
    ParameterType.STRING: ParameterType.STRING_ARRAY,
}


def _scalar_type(obj: object) -> ParameterType | None:
    if isinstance(obj, bool):
        return ParameterType.BOOL
    if isinstance(obj, int):
        return ParameterType.INTEGER
    if isinstance(obj, float):
        return ParameterType.DOUBLE
    if isinstance(obj, str):
        return ParameterType.STRING
    return None


def _check_int(v: int) -> int:
    if not INT64_MIN <= v <= INT64_MAX:
        shown = str(v) if v.bit_length() < 200 else f"of {v.bit_length()} bits"
        raise InvalidValueError(f"integer {shown} does not fit in 64 bits (int64)")
    return v


def _describe(obj: object) -> str:
    if isinstance(obj, (list, tuple)):
        return "a mixed or nested list" if obj else "an empty list"
    try:
        text = repr(obj)
    except Exception:  # a user object whose repr fails still gets a clear message
        text = "<unprintable>"
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(obj).__name__} {text}"


def _type_of(ptype: object) -> ParameterType:
    if isinstance(ptype, ParameterType):
        return ptype
    if isinstance(ptype, int) and not isinstance(ptype, bool) and 0 <= ptype <= 9:
        return ParameterType(ptype)
    raise InvalidValueError(f"unknown parameter type {_describe(ptype)}")


@dataclass(frozen=True, slots=True)
class ParameterValue:
    """One typed value. Build it with :meth:`of` (checked) or :meth:`from_python` (inferred)."""

    type: ParameterType
    value: PyValue = None

    @classmethod
    def of(cls, ptype: ParameterType, value: object) -> ParameterValue:
        """A value of exactly ``ptype``; lists become tuples. No widening here."""
        ptype = _type_of(ptype)
        if ptype is ParameterType.NOT_SET:
            if value is not None:
                raise TypeMismatchError(f"a not_set value carries nothing, got {_describe(value)}")
            return NOT_SET
        if ptype is ParameterType.BYTE_ARRAY:
            return cls(ptype, _to_bytes(value))
        element = ptype.element
        if element is None:
            return cls(ptype, _scalar(ptype, value))
        if not isinstance(value, (list, tuple)):
            raise TypeMismatchError(f"expected a {ptype.label}, got {_describe(value)}")
        return cls(ptype, tuple(_scalar(element, v) for v in value))  # type: ignore[arg-type]

    @classmethod
    def from_python(cls, obj: object) -> ParameterValue:
        """Infer the type: bool, int, float, str, bytes, or a homogeneous list of one of them.

        An empty list has no type of its own; give the type with :meth:`of`.
        """
        if obj is None:
            return NOT_SET
        if isinstance(obj, ParameterValue):
            return obj
        if isinstance(obj, (bytes, bytearray)):
            return cls(ParameterType.BYTE_ARRAY, bytes(obj))
        scalar = _scalar_type(obj)
        if scalar is not None:
            return cls.of(scalar, obj)
        if isinstance(obj, (list, tuple)):
            kinds = {_scalar_type(v) for v in obj}
            if len(kinds) == 1 and None not in kinds:
                (kind,) = kinds
                assert kind is not None
                return cls.of(_ARRAY_OF[kind], obj)
            if kinds == {ParameterType.INTEGER, ParameterType.DOUBLE}:
                raise TypeMismatchError(
                    "a list mixes integers and doubles; write every element as a double (1.0, not 1)"
                )
        raise TypeMismatchError(f"cannot make a parameter value of {_describe(obj)}")

    def coerce(self, target: ParameterType, *, strict: bool = False, name: str = "") -> ParameterValue:
        """This value as ``target``: equal types pass, integer → double widens when exact.

        ``strict`` refuses the widening. A double is never narrowed to an integer.
        """
        target = _type_of(target)
        if self.type is target:
            return self
        widen = {
            (ParameterType.INTEGER, ParameterType.DOUBLE),
            (ParameterType.INTEGER_ARRAY, ParameterType.DOUBLE_ARRAY),
        }
        who = f"Parameter {name!r}" if name else "Value"
        if (self.type, target) in widen:
            if strict:
                raise TypeMismatchError(
                    f"{who} expects a {target.label} but got {self.type.label} {brief(self)}; "
                    f"write it as a double (for example {_as_double_text(self)})"
                )
            return ParameterValue.of(target, _widen(self.value))
        raise TypeMismatchError(f"{who} expects a {target.label} but got {self.type.label} {brief(self)}")

    def show(self) -> str:
        """The value as a user would write it: ``1.5``, ``'abc'``, ``[1, 2]``."""
        v = self.value
        if self.type is ParameterType.NOT_SET:
            return "not_set"
        if isinstance(v, bytes):
            return repr(list(v))
        if isinstance(v, tuple):
            return "[" + ", ".join(_show_scalar(x) for x in v) + "]"
        return _show_scalar(v)

    def to_python(self) -> object:
        """Plain Python: arrays as lists, byte arrays as ``bytes``."""
        return list(self.value) if isinstance(self.value, tuple) else self.value

    def same_as(self, other: ParameterValue) -> bool:
        """The same value exactly (for comparing tables and round trips, and whether a write
        changes anything): NaN equals NaN, and -0.0 is not 0.0 (a change of sign is a change)."""
        if self.type is not other.type:
            return False
        a, b = self.value, other.value
        if isinstance(a, tuple) and isinstance(b, tuple):
            return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
        return _same(a, b)


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))
    return type(a) is type(b) and a == b


def _show_scalar(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return repr(v)
    return str(v)


def _widen(v: PyValue) -> object:
    if isinstance(v, tuple):
        return tuple(_widen_one(x) for x in v)
    return _widen_one(v)


def _widen_one(v: object) -> float:
    assert isinstance(v, int) and not isinstance(v, bool)
    f = float(v)
    if int(f) != v:
        raise TypeMismatchError(f"integer {v} has no exact double; write it as a double")
    return f


def _as_double_text(value: ParameterValue) -> str:
    v = value.value
    if isinstance(v, tuple):
        head = ", ".join(f"{x}.0" for x in v[:5])
        return f"[{head}, ...]" if len(v) > 5 else f"[{head}]"
    assert isinstance(v, int)
    return f"{v}.0"


def brief(value: ParameterValue, limit: int = 200) -> str:
    """:meth:`ParameterValue.show`, cut to ``limit`` characters (for messages)."""
    text = value.show()
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _scalar(ptype: ParameterType, v: object) -> Scalar:
    actual = _scalar_type(v)
    if actual is not ptype:
        raise TypeMismatchError(f"expected a {ptype.label}, got {_describe(v)}")
    if ptype is ParameterType.INTEGER:
        assert isinstance(v, int)
        return _check_int(int.__int__(v))  # drops subclasses such as IntEnum
    if ptype is ParameterType.DOUBLE:
        assert isinstance(v, float)
        return float.__float__(v)
    if ptype is ParameterType.STRING:
        assert isinstance(v, str)
        return _check_str(str.__str__(v))
    assert isinstance(v, bool)
    return v


def _check_str(v: str) -> str:
    # A lone surrogate has no UTF-8 encoding: it could never be sent.
    if not v.isascii():
        try:
            v.encode("utf-8")
        except UnicodeEncodeError:
            raise InvalidValueError("a string value must be valid Unicode (not a lone surrogate)") from None
    return v


def _to_bytes(value: object) -> bytes:
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    if isinstance(value, (list, tuple)) and all(
        isinstance(b, int) and not isinstance(b, bool) and 0 <= b <= 255 for b in value
    ):
        return bytes(value)
    raise TypeMismatchError(f"expected a byte_array (integers 0..255), got {_describe(value)}")


NOT_SET = ParameterValue(ParameterType.NOT_SET, None)


@dataclass(frozen=True, slots=True)
class Parameter:
    """A name and a value: one entry of a set request."""

    name: str
    value: ParameterValue
