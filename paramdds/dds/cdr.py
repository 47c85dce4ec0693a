"""A fast XCDR2 codec for the wire types, byte-identical to cyclonedds-python's.

cyclonedds-python encodes and decodes a sample by walking a generic machine
member by member through a ``Buffer`` object: about 45 µs to decode one state
sample, which was 80-90 % of a monitor's time. Every wire type is a small,
fixed ``@appendable`` struct, so :func:`fast_cdr` compiles each one once into a
list of plain closures over ``struct`` and slices, which does the same in a few
microseconds.

Scope: little-endian delimited XCDR2 (``D_CDR2_LE``, the encoding every
``@appendable`` type gets from this binding on the machines we ship to).
Anything else (big-endian peers, XCDR1, a caller passing a ``Buffer``) goes to
the binding, so behaviour never depends on this module's coverage.
``tests/dds/test_cdr.py`` checks, with generated samples, that both codecs
produce the same bytes and read each other's output.

A sample that cannot be decoded (truncated, a string that is not UTF-8, a
length past its bound) must not stop the thread that takes it: the binding
decodes inside ``DataReader.take``, so an exception there loses the whole batch
and, uncaught, kills the dispatcher. Decoding therefore never raises; it
returns a default instance marked malformed, which :func:`is_malformed` reports
and every handler drops.
"""

from __future__ import annotations

import struct
import typing
from collections.abc import Callable
from typing import Any, TypeVar

from cyclonedds.idl import IdlStruct
from cyclonedds.idl._support import Endianness
from cyclonedds.idl.types import bounded_str, sequence

Decoder = Callable[[bytes, int], tuple[Any, int]]
Encoder = Callable[[bytearray, Any], None]

HEADER = b"\x00\x09\x00\x00"  # D_CDR2 little-endian, no options
_PAD = (b"", b"\0", b"\0\0", b"\0\0\0")
_U32 = struct.Struct("<I")
_U32_PAIR = struct.Struct("<II")
_MALFORMED = "_paramdds_malformed"

# annotation name -> (struct code, size); XCDR2 aligns every member of 4 bytes or more to 4
_PRIMITIVES: dict[str, tuple[str, int]] = {
    "uint8": ("B", 1),
    "int32": ("i", 4),
    "uint32": ("I", 4),
    "int64": ("q", 8),
    "uint64": ("Q", 8),
    "float64": ("d", 8),
}


class MalformedSample(ValueError):
    """The bytes are not a valid encoding of the type."""


def is_malformed(sample: object) -> bool:
    """Whether a sample taken from a reader could not be decoded (see the module doc)."""
    return bool(getattr(sample, _MALFORMED, False))


def _check(condition: bool, what: str) -> None:
    if not condition:
        raise MalformedSample(what)


# ---- primitives -------------------------------------------------------------------------------


def _fixed(code: str, size: int) -> tuple[Decoder, Encoder]:
    packer = struct.Struct("<" + code)
    unpack, pack = packer.unpack_from, packer.pack
    if size == 1:

        def dec1(buf: bytes, pos: int) -> tuple[Any, int]:
            return unpack(buf, pos)[0], pos + 1

        def enc1(out: bytearray, value: Any) -> None:
            out += pack(value)

        return dec1, enc1

    def dec(buf: bytes, pos: int) -> tuple[Any, int]:
        pos += -pos & 3
        return unpack(buf, pos)[0], pos + size

    def enc(out: bytearray, value: Any) -> None:
        out += _PAD[-len(out) & 3]
        out += pack(value)

    return dec, enc


def _string(bound: int | None) -> tuple[Decoder, Encoder]:
    def dec(buf: bytes, pos: int) -> tuple[Any, int]:
        pos += -pos & 3
        (n,) = _U32.unpack_from(buf, pos)
        pos += 4
        end = pos + n
        _check(n > 0 and end <= len(buf) and buf[end - 1] == 0, "bad string length or terminator")
        _check(bound is None or n - 1 <= bound, "string longer than its bound")
        return buf[pos : end - 1].decode("utf-8"), end

    def enc(out: bytearray, value: Any) -> None:
        data = value.encode("utf-8")
        if bound is not None and len(data) > bound:
            raise ValueError(f"string of {len(data)} bytes is longer than its bound of {bound}")
        out += _PAD[-len(out) & 3]
        out += _U32.pack(len(data) + 1)
        out += data
        out += b"\0"

    return dec, enc


def _check_count(n: int, bound: int | None) -> None:
    if bound is not None and n > bound:
        raise ValueError(f"sequence of {n} elements is longer than its bound of {bound}")


def _primitive_sequence(code: str, size: int, bound: int | None) -> tuple[Decoder, Encoder]:
    """A sequence of a primitive: a length, then the elements (no DHEADER)."""

    def dec(buf: bytes, pos: int) -> tuple[Any, int]:
        pos += -pos & 3
        (n,) = _U32.unpack_from(buf, pos)
        pos += 4
        end = pos + n * size
        _check(end <= len(buf), "sequence runs past the sample")
        _check(bound is None or n <= bound, "sequence longer than its bound")
        if code == "B":
            return list(buf[pos:end]), end
        return list(struct.unpack_from(f"<{n}{code}", buf, pos)), end

    def enc(out: bytearray, value: Any) -> None:
        n = len(value)
        _check_count(n, bound)
        out += _PAD[-len(out) & 3]
        out += _U32.pack(n)
        if code == "B":
            out += bytes(value)
        elif code == "?":
            out += bytes(1 if v else 0 for v in value)
        else:
            out += struct.pack(f"<{n}{code}", *value)

    return dec, enc


def _delimited_sequence(element: tuple[Decoder, Encoder], bound: int | None) -> tuple[Decoder, Encoder]:
    """A sequence of strings or structs: a DHEADER (byte size), a length, then the elements."""
    dec_element, enc_element = element

    def dec(buf: bytes, pos: int) -> tuple[Any, int]:
        pos += -pos & 3
        size, n = _U32_PAIR.unpack_from(buf, pos)
        end = pos + 4 + size
        pos += 8
        # every element takes at least 4 bytes: a bound on the loop for hostile lengths
        _check(end <= len(buf) and n * 4 <= size, "sequence runs past the sample")
        _check(bound is None or n <= bound, "sequence longer than its bound")
        items = []
        for _ in range(n):
            item, pos = dec_element(buf, pos)
            items.append(item)
        _check(pos <= end, "sequence elements run past its size")
        return items, end

    def enc(out: bytearray, value: Any) -> None:
        _check_count(len(value), bound)
        out += _PAD[-len(out) & 3]
        at = len(out)
        out += _U32_PAIR.pack(0, len(value))
        for item in value:
            enc_element(out, item)
        _U32.pack_into(out, at, len(out) - at - 4)

    return dec, enc


# ---- structs ----------------------------------------------------------------------------------

_codecs: dict[type, tuple[Decoder, Encoder]] = {}


def _struct(cls: type) -> tuple[Decoder, Encoder]:
    """An ``@appendable`` struct: a DHEADER (byte size), then the members in order.

    Members past the size keep their defaults (an older writer); bytes past the
    last known member are skipped (a newer writer)."""
    if cls in _codecs:
        return _codecs[cls]
    hints = typing.get_type_hints(cls, include_extras=True)
    members = [(name, _member(hint)) for name, hint in hints.items()]
    decoders = [(name, dec) for name, (dec, _) in members]
    encoders = [(name, enc) for name, (_, enc) in members]

    def dec(buf: bytes, pos: int) -> tuple[Any, int]:
        pos += -pos & 3
        (size,) = _U32.unpack_from(buf, pos)
        pos += 4
        end = pos + size
        _check(end <= len(buf), "struct runs past the sample")
        values = {}
        for name, dec_member in decoders:
            if pos >= end:
                break
            values[name], pos = dec_member(buf, pos)
        _check(pos <= end, "members run past the struct's size")
        return cls(**values), end

    def enc(out: bytearray, value: Any) -> None:
        out += _PAD[-len(out) & 3]
        at = len(out)
        out += b"\0\0\0\0"
        for name, enc_member in encoders:
            enc_member(out, getattr(value, name))
        _U32.pack_into(out, at, len(out) - at - 4)

    _codecs[cls] = (dec, enc)
    return dec, enc


def _primitive(hint: Any) -> tuple[str, int] | None:
    """(struct code, size) of ``bool`` or an ``Annotated[int, "uint8"]``-style primitive."""
    if hint is bool:
        return ("?", 1)
    args = typing.get_args(hint)
    if len(args) == 2 and isinstance(args[1], str):
        return _PRIMITIVES[args[1]]
    return None


def _member(hint: Any) -> tuple[Decoder, Encoder]:
    primitive = _primitive(hint)
    if primitive is not None:
        return _fixed(*primitive)
    if hint is str:
        return _string(None)
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return _struct(hint)
    meta = typing.get_args(hint)[1]  # Annotated[python type, cyclonedds annotation]
    if isinstance(meta, bounded_str):
        return _string(meta.max_length)
    if isinstance(meta, sequence):
        element = _primitive(meta.subtype)
        if element is not None:
            return _primitive_sequence(*element, meta.max_length)
        return _delimited_sequence(_member(meta.subtype), meta.max_length)
    raise TypeError(f"no fast codec for {hint!r}")  # a new kind of member: extend this module


# ---- installing on a type ---------------------------------------------------------------------

T = TypeVar("T", bound=type[IdlStruct])


def encode(sample: IdlStruct) -> bytes:
    out = bytearray(HEADER)
    _struct(type(sample))[1](out, sample)
    return bytes(out)


def decode(cls: type[IdlStruct], data: bytes) -> Any:
    """Decode a sample with its encapsulation header; raises MalformedSample."""
    try:
        sample, _ = _struct(cls)[0](data, 4)
    except MalformedSample:
        raise
    except (struct.error, ValueError, IndexError) as exc:  # UnicodeDecodeError is a ValueError
        raise MalformedSample(str(exc)) from exc
    return sample


def fast_cdr(cls: T) -> T:
    """Class decorator: route the type's (de)serialization through this codec."""

    def serialize(
        self: IdlStruct,
        buffer: Any = None,
        endianness: Endianness | None = None,
        use_version_2: bool | None = None,
    ) -> bytes:
        if buffer is None and endianness in (None, Endianness.Little) and use_version_2 is not False:
            return encode(self)
        return IdlStruct.serialize(self, buffer, endianness, use_version_2)

    def deserialize(
        klass: type[IdlStruct], data: bytes, has_header: bool = True, use_version_2: bool | None = None
    ) -> Any:
        try:
            if has_header and data[:2] == HEADER[:2]:
                return decode(klass, data)
            return klass.__idl__.deserialize(data, has_header, use_version_2)  # type: ignore[arg-type]
        except Exception:  # any undecodable sample, whichever codec read it
            sample = klass()
            setattr(sample, _MALFORMED, True)
            return sample

    cls.serialize = serialize  # type: ignore[method-assign]
    cls.deserialize = classmethod(deserialize)  # type: ignore[method-assign,assignment]
    return cls
