"""The value and the descriptor of a ``ParameterEvents`` sample, read and written straight
between XCDR1 bytes and core objects (for :mod:`.state`).

The layout is :mod:`.cdr`'s: plain XCDR1 little endian, offsets counted from the start
of the stream (the 4-byte encapsulation header included), so ``-pos & 3`` aligns to 4
and ``(4 - pos) & 7`` aligns to 8 after the header. A ``ParameterValue`` is
``type bool pad-to-8 int64 double string`` and five sequences (byte, bool, int64,
double, string); a ``ParameterDescriptor`` is ``name type description
additional_constraints read_only dynamic_typing``, two ranges (sequences of at most one
struct) and its validators (``kind`` and a sequence of values).

A reader returns exactly what the generated codec and :mod:`.convert` build from the
same bytes (same types: ``bytes`` for byte arrays, tuples of ``bool`` for bool arrays),
or raises :data:`REFUSED` for anything it does not read in full: another writer's
non-empty sequence beside the value's own, an unknown type byte, a sequence over its
bound, truncated or damaged bytes. The caller then hands the sample to the slow path,
which decides what it is. A writer appends exactly the generated encoder's bytes, or
raises :data:`UNWRITTEN` where that encoder might fail (a number out of range, text that
is no Unicode, an object that is no core value): the caller then lets it decide.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from ...core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from ...core.values import NOT_SET, ParameterType, ParameterValue, PyValue
from .cdr import encode_str

__all__ = [
    "BOOL",
    "DOUBLE",
    "INTEGER",
    "REFUSED",
    "STRING",
    "UNWRITTEN",
    "NotFast",
    "finish_value",
    "read_descriptor",
    "read_str",
    "write_arrays",
    "write_descriptor",
]


class NotFast(Exception):
    """Bytes the fast readers do not read (the slow path decides what they are)."""


# what a reader raises on bytes it does not read in full
REFUSED = (NotFast, struct.error, IndexError, UnicodeDecodeError)
# what a writer raises on values it does not write
UNWRITTEN = (struct.error, UnicodeEncodeError, TypeError, AttributeError, ValueError)

_TYPES = tuple(ParameterType)  # index == type byte
# type bytes as plain ints: looking up an IntEnum member costs ~70 ns, a tenth of the hot path
BOOL, INTEGER, DOUBLE, STRING, BYTE_ARRAY = (int(t) for t in _TYPES[1:6])
_u32 = struct.Struct("<I")
_unpack_u32 = _u32.unpack_from
_pack_u32 = _u32.pack
_VALUE_NUMBERS = struct.Struct("<qdI")  # integer_value, double_value (8-aligned), string_value's length
_INTEGER_RANGE = struct.Struct("<qqQ")  # from_value, to_value, step
_FLOATING_RANGE = struct.Struct("<ddd")
_NO_ARRAYS = bytes(20)  # the five sequences of a value, all empty
_PAD = tuple(bytes(n) for n in range(8))


# ---- reading ----------------------------------------------------------------------------------


def read_str(buf: bytes, pos: int, end: int) -> tuple[str, int]:
    """An unbounded string at ``pos`` (aligned here); the string, the offset after it."""
    pos += -pos & 3
    (n,) = _unpack_u32(buf, pos)
    e = pos + 4 + n
    if n == 0 or e > end or buf[e - 1] != 0:
        raise NotFast("bad string length or terminator")
    return buf[pos + 4 : e - 1].decode(), e


def read_value(buf: bytes, pos: int, end: int) -> tuple[ParameterValue, int]:
    """A ``ParameterValue`` starting at ``pos`` (any offset: XCDR1 does not align structs)."""
    t = buf[pos]
    b = buf[pos + 1] != 0
    pos += 2
    pos += (4 - pos) & 7
    i, d, n = _VALUE_NUMBERS.unpack_from(buf, pos)
    return finish_value(buf, pos + _VALUE_NUMBERS.size, end, t, b, i, d, n)


def finish_value(
    buf: bytes, pos: int, end: int, t: int, b: bool, i: int, d: float, n: int
) -> tuple[ParameterValue, int]:
    """The rest of a value, from its string's bytes (``n`` with the NUL) at ``pos``, given
    the members before them; the value as :func:`.convert.value_from_wire` builds it."""
    e = pos + n
    if t >= len(_TYPES) or n == 0 or e > end or buf[e - 1] != 0:
        raise NotFast("unknown type byte, or a bad string")
    s = buf[pos : e - 1].decode()
    pos = e + (-e & 3)
    if buf[pos : pos + 20] == _NO_ARRAYS:
        if 0 < t <= STRING:
            return ParameterValue(_TYPES[t], (b, i, d, s)[t - 1]), pos + 20
        return _EMPTY_VALUES[t], pos + 20
    k = t - BYTE_ARRAY  # which of the five sequences is the value's own
    if k < 0 or buf[pos : pos + 4 * k] != _NO_ARRAYS[: 4 * k]:
        raise NotFast("a sequence beside the value's own holds elements")
    items, pos = _SEQUENCES[k](buf, pos + 4 * k, end)
    rest = 4 * (4 - k)  # the empty sequences after it (none after a string array: no padding)
    if rest:
        pos += -pos & 3
        if buf[pos : pos + rest] != _NO_ARRAYS[:rest]:
            raise NotFast("a sequence beside the value's own holds elements")
    return ParameterValue(_TYPES[t], items), pos + rest


# the value of each type byte whose five sequences are empty, where it is no scalar
# (indices 1 to 4, the scalars, are built from their member and never read here)
_EMPTY_VALUES: tuple[ParameterValue, ...] = (
    (NOT_SET,) * 5
    + (ParameterValue(ParameterType.BYTE_ARRAY, b""),)
    + tuple(ParameterValue(t, ()) for t in _TYPES[ParameterType.BOOL_ARRAY :])
)


def _count(buf: bytes, pos: int, end: int) -> tuple[int, int]:
    """A sequence's length at ``pos`` (4-aligned) and the offset after it; refused when even
    one byte per element would run past the sample (never loop over a damaged count)."""
    (n,) = _unpack_u32(buf, pos)
    pos += 4
    if n > end - pos:
        raise NotFast("sequence longer than the sample")
    return n, pos


def _byte_items(buf: bytes, pos: int, end: int) -> tuple[bytes, int]:
    n, pos = _count(buf, pos, end)
    return buf[pos : pos + n], pos + n


def _bool_items(buf: bytes, pos: int, end: int) -> tuple[tuple[bool, ...], int]:
    n, pos = _count(buf, pos, end)
    return tuple(map(bool, buf[pos : pos + n])), pos + n


_Reader = Callable[[bytes, int, int], tuple[Any, int]]


def _numbers(code: str) -> _Reader:
    def read(buf: bytes, pos: int, end: int) -> tuple[tuple[Any, ...], int]:
        n, pos = _count(buf, pos, end)
        if not n:
            return (), pos
        pos += (4 - pos) & 7  # elements aligned to 8 only when there are some
        return struct.unpack_from(f"<{n}{code}", buf, pos), pos + 8 * n

    return read


def _string_items(buf: bytes, pos: int, end: int) -> tuple[tuple[str, ...], int]:
    n, pos = _count(buf, pos, end)
    items = []
    for _ in range(n):
        s, pos = read_str(buf, pos, end)
        items.append(s)
    return tuple(items), pos


_SEQUENCES: tuple[_Reader, ...] = (_byte_items, _bool_items, _numbers("q"), _numbers("d"), _string_items)


def read_descriptor(buf: bytes, pos: int, end: int) -> tuple[ParameterDescriptor, int]:
    """A ``ParameterDescriptor`` at ``pos``, as :func:`.convert.descriptor_from_wire` builds it."""
    name, pos = read_str(buf, pos, end)
    t = buf[pos]
    if t >= len(_TYPES):
        raise NotFast("unknown type byte")
    description, pos = read_str(buf, pos + 1, end)
    constraints, pos = read_str(buf, pos, end)
    read_only, dynamic_typing = buf[pos] != 0, buf[pos + 1] != 0
    integer_range, pos = _range(buf, pos + 2, _INTEGER_RANGE)
    floating_range, pos = _range(buf, pos, _FLOATING_RANGE)
    validators, pos = _validators(buf, pos, end)
    return (
        ParameterDescriptor(
            name,
            _TYPES[t],
            description,
            constraints,
            read_only,
            dynamic_typing,
            None if integer_range is None else IntegerRange(*integer_range),
            None if floating_range is None else FloatingPointRange(*floating_range),
            validators,
        ),
        pos,
    )


def _range(buf: bytes, pos: int, codec: struct.Struct) -> tuple[tuple[Any, Any, Any] | None, int]:
    """A range: a sequence of at most one struct of three 8-byte numbers."""
    pos += -pos & 3
    (n,) = _unpack_u32(buf, pos)
    pos += 4
    if n == 0:
        return None, pos
    if n > 1:
        raise NotFast("a range sequence over its bound of 1")
    pos += (4 - pos) & 7
    return codec.unpack_from(buf, pos), pos + codec.size


def _validators(buf: bytes, pos: int, end: int) -> tuple[tuple[Validator, ...], int]:
    n, pos = _count(buf, pos + (-pos & 3), end)
    validators = []
    for _ in range(n):
        kind, pos = read_str(buf, pos, end)
        m, pos = _count(buf, pos + (-pos & 3), end)
        args = []
        for _ in range(m):
            arg, pos = read_value(buf, pos, end)
            args.append(arg)
        validators.append(Validator(kind, tuple(args)))
    return tuple(validators), pos


# ---- writing ----------------------------------------------------------------------------------


def write_value(out: bytearray, v: ParameterValue) -> None:
    """A value at any offset, as the generated encoder writes :func:`.convert.value_to_wire`."""
    t, x = int(v.type), v.value
    out.append(t)
    out.append(1 if t == BOOL and x else 0)
    out += _PAD[(4 - len(out)) & 7]
    s = x.encode() if isinstance(x, str) else b""
    out += _VALUE_NUMBERS.pack(x if t == INTEGER else 0, x if t == DOUBLE else 0.0, len(s) + 1)
    out += s
    out.append(0)
    write_arrays(out, t, x)


def write_arrays(out: bytearray, t: int, x: PyValue) -> None:
    """The five sequences of a value of type byte ``t`` and Python value ``x``, after its
    string: all empty but an array value's own."""
    out += _PAD[-len(out) & 3]
    if t < BYTE_ARRAY or not x:
        out += _NO_ARRAYS
        return
    if not isinstance(x, (bytes, tuple)):  # a core value is never else: the generated encoder decides
        raise TypeError(f"an array value of {type(x).__name__}")
    k = t - BYTE_ARRAY
    out += _NO_ARRAYS[: 4 * k]
    out += _pack_u32(len(x))
    if k == 0:
        out += bytes(x)  # type: ignore[arg-type]
    elif k == 1:
        out += bytes(map(bool, x))
    elif k == 4:
        for item in x:
            encode_str(out, item)  # type: ignore[arg-type]
    else:
        out += _PAD[(4 - len(out)) & 7]
        out += struct.pack(f"<{len(x)}{'q' if k == 2 else 'd'}", *x)
    if k < 4:  # the empty sequences after it (a string array is the last: no padding)
        out += _PAD[-len(out) & 3]
        out += _NO_ARRAYS[: 4 * (4 - k)]


def write_descriptor(out: bytearray, d: ParameterDescriptor) -> None:
    """A descriptor, as the generated encoder writes :func:`.convert.descriptor_to_wire`."""
    encode_str(out, d.name)
    out.append(int(d.type))
    encode_str(out, d.description)
    encode_str(out, d.additional_constraints)
    out.append(1 if d.read_only else 0)
    out.append(1 if d.dynamic_typing else 0)
    ir, fr = d.integer_range, d.floating_point_range
    _write_range(out, _INTEGER_RANGE, None if ir is None else (ir.from_value, ir.to_value, ir.step))
    _write_range(out, _FLOATING_RANGE, None if fr is None else (fr.from_value, fr.to_value, fr.step))
    out += _PAD[-len(out) & 3]
    out += _pack_u32(len(d.validators))
    for validator in d.validators:
        encode_str(out, validator.kind)
        out += _PAD[-len(out) & 3]
        out += _pack_u32(len(validator.args))
        for arg in validator.args:
            write_value(out, arg)


def _write_range(out: bytearray, codec: struct.Struct, numbers: tuple[float, float, float] | None) -> None:
    out += _PAD[-len(out) & 3]
    if numbers is None:
        out += _PAD[4]
        return
    out += _pack_u32(1)
    out += _PAD[(4 - len(out)) & 7]
    out += codec.pack(*numbers)
