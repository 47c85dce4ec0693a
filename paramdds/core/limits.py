"""Size limits, checked before Cyclone ever sees the data.

Cyclone counts bounded strings in bytes while Python counts characters, and an
oversized sample fails deep inside the C library with no parameter name in the
message. So every value is measured here first and refused with a
:class:`~paramdds.errors.TooLargeError` that names the parameter and the limit.

:func:`value_size` approximates the encoded size of one value: the UTF-8 bytes
of a string, one byte per bool or byte, eight per integer or double, and for a
string array the UTF-8 bytes of each element plus one (its terminating NUL on
the wire). Fixed per-sample overhead is ignored: the limits leave room for it.
"""

from __future__ import annotations

from ..errors import TooLargeError
from .values import ParameterType, ParameterValue

__all__ = [
    "MAX_NAME_BYTES",
    "MAX_NODE_ID_BYTES",
    "MAX_PARAMETERS_PER_REQUEST",
    "MAX_STRING_BYTES",
    "MAX_VALUE_BYTES",
    "check_request_size",
    "check_text",
    "check_value",
    "value_size",
]

MAX_NAME_BYTES = 255
MAX_NODE_ID_BYTES = 255
MAX_PARAMETERS_PER_REQUEST = 65536
MAX_VALUE_BYTES = 4 * 1024 * 1024
MAX_STRING_BYTES = 64 * 1024  # descriptions and additional_constraints


def check_request_size(count: int, what: str = "set") -> None:
    """The one home of the request-size rule: a set of more than
    :data:`MAX_PARAMETERS_PER_REQUEST` parameters, or a get of more names, is refused whole
    with TOO_LARGE, before anything runs. Every entry point calls this: the table (each
    parameter's result says it), the client (raised before sending), the server (the
    reply's code), the ROS 2 mirror (as the table)."""
    if count > MAX_PARAMETERS_PER_REQUEST:
        unit = "names" if what == "get" else "parameters"
        raise TooLargeError(f"a {what} of {count} {unit} exceeds the limit of {MAX_PARAMETERS_PER_REQUEST}")


_FIXED = {
    ParameterType.NOT_SET: 0,
    ParameterType.BOOL: 1,
    ParameterType.INTEGER: 8,
    ParameterType.DOUBLE: 8,
}
_ELEMENT = {
    ParameterType.BYTE_ARRAY: 1,
    ParameterType.BOOL_ARRAY: 1,
    ParameterType.INTEGER_ARRAY: 8,
    ParameterType.DOUBLE_ARRAY: 8,
}


def _utf8_len(s: str) -> int:
    return len(s) if s.isascii() else len(s.encode("utf-8", "surrogatepass"))


def value_size(v: ParameterValue) -> int:
    """The approximate encoded size of ``v`` in bytes (see the module docstring)."""
    fixed = _FIXED.get(v.type)
    if fixed is not None:
        return fixed
    data = v.value
    if v.type is ParameterType.STRING:
        assert isinstance(data, str)
        return _utf8_len(data)
    assert isinstance(data, (bytes, tuple))
    per = _ELEMENT.get(v.type)
    if per is not None:
        return per * len(data)
    return sum(_utf8_len(s) + 1 for s in data if isinstance(s, str))


def check_value(name: str, v: ParameterValue) -> None:
    """Raise TooLargeError when ``v`` is over :data:`MAX_VALUE_BYTES`."""
    size = value_size(v)
    if size > MAX_VALUE_BYTES:
        raise TooLargeError(
            f"Parameter {name!r}: its {v.type.label} value is about {size} bytes; "
            f"the limit is {MAX_VALUE_BYTES} bytes (4 MiB)"
        )


def check_text(name: str, field: str, text: str) -> None:
    """Raise TooLargeError when a descriptor's text ``field`` is over :data:`MAX_STRING_BYTES`."""
    size = _utf8_len(text)
    if size > MAX_STRING_BYTES:
        raise TooLargeError(
            f"Parameter {name!r}: its {field} is {size} bytes; the limit is {MAX_STRING_BYTES} bytes"
        )
