"""A fast XCDR1 codec for the wire types, byte-identical to cyclonedds-python's.

cyclonedds-python encodes and decodes a sample by walking a generic machine
member by member through a ``Buffer`` object: ~90 µs to decode one state sample
here, most of a monitor's time. Every wire type is a small ``@final`` struct, so
this module writes straight-line functions per struct instead (Python source
from the templates below, compiled on first use, as ``dataclasses`` does for
``__init__``): an encoder, and a decoder that reads runs of fixed-size members
at once. ``source(cls)`` shows the generated code. (Two threads compiling the
same struct at once both get correct functions; one set is kept.)

Scope: little-endian plain XCDR1 (``CDR_LE``, encapsulation ``00 01``), what the
binding writes for ``@final`` types and what every DDS vendor reads. Anything
else (big-endian peers, XCDR2 from a peer that prefers it, a caller passing a
``Buffer``) goes to the binding, so behaviour never depends on this module's
coverage. ``tests/dds/test_cdr.py`` checks, with generated samples, that both
codecs write the same bytes and read each other's output.

XCDR1 rules: no headers inside the sample; each primitive is aligned to its
size (up to 8) counted from the end of the 4-byte encapsulation header; a
string or sequence is a 4-byte count, then its elements (a string's bytes end
with a NUL, counted); a nested struct is its members, with no alignment of its
own. The binding pads nothing at the end.

A sample that cannot be decoded (truncated, a string that is not UTF-8, a
length past its bound) must not stop the thread that takes it: the binding
decodes inside ``DataReader.take``, so an exception there loses the whole batch
and, uncaught, kills the dispatcher. Decoding through a reader therefore never
raises; it returns a default instance marked malformed, which
:func:`is_malformed` reports and the dispatcher drops.
"""

from __future__ import annotations

import struct
import typing
from typing import Any, NamedTuple, TypeVar

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import bounded_str, sequence

from .._binding import Endianness, binding_deserialize

HEADER = b"\x00\x01\x00\x00"  # CDR_LE (plain XCDR1, little-endian), no options
_MALFORMED = "_paramdds_malformed"

# annotation -> struct code (its size is its alignment)
_CODES = {"int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float64": "d"}


class MalformedSample(ValueError):
    """The bytes are not a valid encoding of the type."""


def is_malformed(sample: object) -> bool:
    """Whether a sample taken from a reader could not be decoded (see the module doc)."""
    return bool(getattr(sample, _MALFORMED, False))


# ---- code templates, one per kind of member -----------------------------------------------------
#
# Decoding reads ``buf`` (bytes, offset 0 is the start of the encapsulation header) at
# ``pos`` and must stay within ``end`` (its length); encoding appends to ``out`` (a
# bytearray that starts with the header too). Alignment counts from the end of the
# header, offset 4: ``(4 - pos) & 7`` is the padding that brings ``pos`` to a multiple
# of 8 after it. ``{v}`` is the member's variable, ``{c}`` a struct code, ``{a}`` an
# alignment mask (size - 1), ``{b}`` a bound (``{bcheck}`` its test, empty when unbounded;
# lines marked ``[bounded]`` are dropped then), ``{f}`` a nested function's name.

_ALIGN = "pos += (4 - pos) & {a}"
_OUT_ALIGN = "out += PAD[(4 - len(out)) & {a}]"
_ALIGN4 = _ALIGN.replace("{a}", "3")
_OUT_ALIGN4 = _OUT_ALIGN.replace("{a}", "3")

_DECODE = {
    "byte": ["{v} = buf[pos]", "pos += 1"],
    "bool": ["{v} = buf[pos] != 0", "pos += 1"],
    "fixed": [_ALIGN, "({v},) = unpack_{c}(buf, pos)", "pos += {size}"],
    "string": [
        _ALIGN4,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "e = pos + n",
        "if n == 0{bcheck} or e > end or buf[e - 1] != 0:",
        "    raise MalformedSample('bad string length, bound or terminator')",
        "{v} = buf[pos : e - 1].decode()",
        "pos = e",
    ],
    "bytes": [  # sequence<octet> and sequence<boolean>: one byte each; most sequences are empty
        _ALIGN4,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "if n:",
        "    e = pos + n",
        "    if e > end{bcheck}:",
        "        raise MalformedSample('sequence past its bound or the sample')",
        "    {v} = {convert}",
        "    pos = e",
        "else:",
        "    {v} = []",
    ],
    "array": [  # sequence of 4- or 8-byte primitives; elements aligned only when there are some
        _ALIGN4,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "if n:",
        "    " + _ALIGN,
        "    e = pos + n * {size}",
        "    if e > end{bcheck}:",
        "        raise MalformedSample('sequence past its bound or the sample')",
        "    {v} = list(unpack_from('<%d{c}' % n, buf, pos))",
        "    pos = e",
        "else:",
        "    {v} = []",
    ],
    "elements": [  # sequence of strings or structs: count, elements
        _ALIGN4,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "if n > end - pos{bcheck}:",  # every element takes at least a byte
        "    raise MalformedSample('sequence past its bound or the sample')",
        "{v} = []",
        "for _ in range(n):",
        "    x, pos = {f}(buf, pos, end)",
        "    {v}.append(x)",
    ],
    "struct": ["{v}, pos = {f}(buf, pos, end)"],
}

_ENCODE = {
    "byte": ["out.append({v})"],
    "bool": ["out.append(1 if {v} else 0)"],
    "fixed": [_OUT_ALIGN, "out += pack_{c}({v})"],
    "string": [
        "data = {v}.encode()",
        "[bounded]if len(data) > {b} - 1:",
        "[bounded]    raise ValueError(f'string of {{len(data)}} bytes is longer than its bound of {bmsg}')",
        _OUT_ALIGN4,
        "out += pack_I(len(data) + 1)",
        "out += data",
        "out.append(0)",
    ],
    # most sequences are empty (a value uses one of its five): one append for those
    "bytes": [
        "[bounded]check_count(len({v}), {b})",
        _OUT_ALIGN4,
        "if {v}:",
        "    out += pack_I(len({v}))",
        "    out += bytes({convert})",
        "else:",
        "    out += EMPTY",
    ],
    "array": [
        "[bounded]check_count(len({v}), {b})",
        _OUT_ALIGN4,
        "if {v}:",
        "    out += pack_I(len({v}))",
        "    " + _OUT_ALIGN,
        "    out += pack('<%d{c}' % len({v}), *{v})",
        "else:",
        "    out += EMPTY",
    ],
    "elements": [
        "[bounded]check_count(len({v}), {b})",
        _OUT_ALIGN4,
        "out += pack_I(len({v}))",
        "for x in {v}:",
        "    {f}(out, x)",
    ],
    "struct": ["{f}(out, {v})"],
}

_NO_BOUND = 0xFFFFFFFF  # a sequence length or string size can never exceed a uint32


class _Member(NamedTuple):
    kind: str  # a key of _DECODE / _ENCODE
    code: str = ""  # struct code ("fixed", "array")
    bound: int = _NO_BOUND  # elements, or bytes of a string including its NUL
    nested: str = ""  # the function name prefix of a struct or string element
    convert_in: str = ""  # "bytes": list from the slice
    convert_out: str = ""  # "bytes": iterable for bytes()

    def lines(self, templates: dict[str, list[str]], var: str, fn: str) -> list[str]:
        bmsg = self.bound - 1 if self.kind == "string" else self.bound
        size = struct.calcsize("<" + self.code) if self.code else 0
        fields = {"v": var, "c": self.code, "size": size, "a": size - 1, "b": self.bound, "bmsg": bmsg}
        fields["f"] = fn
        fields["convert"] = (self.convert_in if templates is _DECODE else self.convert_out).format(**fields)
        bounded = self.bound != _NO_BOUND
        fields["bcheck"] = f" or n > {self.bound}" if bounded else ""
        lines = templates[self.kind]
        if not bounded:  # lines marked [bounded] check a bound: unbounded members skip them
            lines = [line for line in lines if not line.startswith("[bounded]")]
        return [line.removeprefix("[bounded]").format(**fields) for line in lines]


def _member(hint: Any, functions: dict[str, Any]) -> _Member:
    """How one annotated member is coded; nested structs get their functions in ``functions``."""
    if hint is bool:
        return _Member("bool")
    if hint is str:
        return _Member("string", nested="str")
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return _Member("struct", nested=_compile(hint, functions))
    meta = typing.get_args(hint)[1]  # Annotated[python type, cyclonedds annotation]
    if isinstance(meta, str):
        return _Member("byte") if meta in ("byte", "uint8") else _Member("fixed", _CODES[meta])
    if isinstance(meta, bounded_str):
        return _Member("string", bound=meta.max_length + 1, nested="str")
    if isinstance(meta, sequence):
        bound = meta.max_length or _NO_BOUND
        element = _member(meta.subtype, functions)
        if element.kind == "byte":
            return _Member("bytes", bound=bound, convert_in="list(buf[pos:e])", convert_out="{v}")
        if element.kind == "bool":
            return _Member(
                "bytes", bound=bound, convert_in="[b != 0 for b in buf[pos:e]]", convert_out="map(bool, {v})"
            )
        if element.kind == "fixed":
            return _Member("array", element.code, bound)
        if element.kind in ("string", "struct") and element.bound == _NO_BOUND:
            return _Member("elements", bound=bound, nested=element.nested)
    raise TypeError(f"no fast codec for {hint!r}")  # a new kind of member: extend this module


def check_count(n: int, bound: int) -> None:
    if n > bound:
        raise ValueError(f"sequence of {n} elements is longer than its bound of {bound}")


def _str_decode(buf: bytes, pos: int, end: int) -> tuple[str, int]:
    """A string as a sequence element."""
    pos += -pos & 3  # the header is 4 bytes: 4-alignment is the same from either end of it
    (n,) = struct.unpack_from("<I", buf, pos)
    pos += 4
    e = pos + n
    if n == 0 or e > end or buf[e - 1] != 0:
        raise MalformedSample("bad string length or terminator")
    return buf[pos : e - 1].decode(), e


def encode_str(out: bytearray, value: str) -> None:
    """Append a string at the next 4-byte boundary: length with the NUL, UTF-8, NUL."""
    data = value.encode()
    out += b"\0" * (-len(out) & 3)
    out += struct.pack("<I", len(data) + 1)
    out += data
    out.append(0)


# ---- compiling a struct -------------------------------------------------------------------------

_BASE_NAMESPACE: dict[str, Any] = {
    "unpack_from": struct.unpack_from,
    "pack": struct.pack,
    **{f"unpack_{c}": struct.Struct("<" + c).unpack_from for c in ("I", *_CODES.values())},
    **{f"pack_{c}": struct.Struct("<" + c).pack for c in ("I", *_CODES.values())},
    "PAD": tuple(bytes(n) for n in range(8)),
    "EMPTY": b"\0\0\0\0",  # a sequence's length, 0
    "MalformedSample": MalformedSample,
    "check_count": check_count,
    "decode_str": _str_decode,
    "encode_str": encode_str,
}
_compiled: dict[type, _Functions] = {}


def _compile(cls: type, functions: dict[str, Any]) -> str:
    """Generate the functions of ``cls`` (see :class:`_Functions`) into ``functions``; its name."""
    name = cls.__name__
    if cls not in _compiled:
        hints = typing.get_type_hints(cls, include_extras=True)
        members = [(field, _member(hint, functions)) for field, hint in hints.items()]
        packers: dict[str, Any] = {}
        source = "\n\n\n".join("\n".join(f) for f in _decoder_and_encoder(name, members, packers))
        namespace = dict(_BASE_NAMESPACE, cls=cls, **functions, **packers)
        exec(compile(source + "\n", f"<paramdds.dds.wire.cdr {name}>", "exec"), namespace)
        _compiled[cls] = _Functions(namespace[f"decode_{name}"], namespace[f"encode_{name}"], source + "\n")
    compiled = _compiled[cls]
    functions.update({f"decode_{name}": compiled.decode, f"encode_{name}": compiled.encode})
    return name


def _decoder_and_encoder(
    name: str, members: list[tuple[str, _Member]], packers: dict[str, Any]
) -> tuple[list[str], list[str]]:
    """Member by member, runs of fixed-size members read and written at once.

    Where the offset modulo the next member's alignment is known, a run of
    fixed-size members becomes one ``struct`` format with its padding spelled out
    (``<B?xxxxxxqd`` for ParameterValue's first four, once aligned). A struct may
    start at any offset (XCDR1 does not align nested structs), so the offset is
    unknown at the start and after a string; it is aligned at run time where a
    member needs it, and known from there on.
    """
    dec = [f"def decode_{name}(buf, pos, end):"]
    enc = [f"def encode_{name}(out, obj):"]
    phase, modulus = 0, 1  # the offset after the header is `phase` modulo `modulus` (1: unknown)
    run: list[tuple[str, str, str]] = []  # (variable, field, format with padding) to read at once

    def flush() -> None:
        if run:
            packer = struct.Struct("<" + "".join(piece for _, _, piece in run))
            label = f"{run[0][0]}_to_{run[-1][0]}"  # e.g. m0_to_m3, format in the comment
            packers[f"unpack_{label}"], packers[f"pack_{label}"] = packer.unpack_from, packer.pack
            dec.append(
                f"    ({', '.join(v for v, _, _ in run)},) = unpack_{label}(buf, pos)  # {packer.format}"
            )
            dec.append(f"    pos += {packer.size}")
            enc.append(f"    out += pack_{label}({', '.join('obj.' + f for _, f, _ in run)})")
            run.clear()

    for i, (field, member) in enumerate(members):
        var = f"m{i}"
        size = {"byte": 1, "bool": 1, "fixed": struct.calcsize("<" + member.code)}.get(member.kind, 0)
        if size == 1 and modulus == 1:  # offset unknown and no alignment needed: inline, no run
            dec += ["    " + line for line in member.lines(_DECODE, var, "")]
            enc += [f"    {var} = obj.{field}", *("    " + line for line in member.lines(_ENCODE, var, ""))]
        elif size:
            if modulus < size:  # align at run time; from here the offset is known
                flush()
                dec.append(f"    {_ALIGN.format(a=size - 1)}")
                enc.append(f"    {_OUT_ALIGN.format(a=size - 1)}")
                phase, modulus = 0, size
            pad = -phase % size
            run.append((var, field, "x" * pad + ("?" if member.kind == "bool" else member.code or "B")))
            phase = (phase + pad + size) % modulus
        else:
            flush()
            dec += ["    " + line for line in member.lines(_DECODE, var, f"decode_{member.nested}")]
            enc += [
                f"    {var} = obj.{field}",
                *("    " + line for line in member.lines(_ENCODE, var, f"encode_{member.nested}")),
            ]
            # after a sequence of 4- or 8-byte elements the offset is a multiple of 4; else unknown
            phase, modulus = (0, 4) if member.kind == "array" else (0, 1)
    flush()
    dec.append(f"    return cls({', '.join(f'm{i}' for i in range(len(members)))}), pos")
    if len(enc) == 1:
        enc.append("    pass")
    return dec, enc


class _Functions(NamedTuple):
    decode: Any  # (buf, pos, end) -> (sample, pos after it); raises on bytes that are no sample
    encode: Any  # (out, sample) -> None
    source: str


def _codec(cls: type) -> _Functions:
    if cls not in _compiled:
        _compile(cls, {})
    return _compiled[cls]


def source(cls: type[IdlStruct]) -> str:
    """The generated decode and encode functions of ``cls``, for reading and debugging."""
    return _codec(cls).source


def encode(sample: IdlStruct) -> bytes:
    out = bytearray(HEADER)
    _codec(type(sample)).encode(out, sample)
    return bytes(out)


def decode(cls: type[IdlStruct], data: bytes) -> Any:
    """Decode a sample with its encapsulation header; raises MalformedSample.

    Bytes after the last member are ignored: a writer may pad a sample to a
    multiple of 4 (Cyclone C does, and says so in the header's option bits).
    """
    try:
        return _codec(cls).decode(data, 4, len(data))[0]
    except MalformedSample:
        raise
    except (struct.error, ValueError, IndexError) as exc:  # incl. UnicodeDecodeError
        raise MalformedSample(str(exc) or type(exc).__name__) from exc


# ---- installing on a type -----------------------------------------------------------------------

T = TypeVar("T", bound=type[IdlStruct])


def fast_cdr(cls: T) -> T:
    """Class decorator: route the type's (de)serialization through this codec."""

    def serialize(
        self: IdlStruct,
        buffer: Any = None,
        endianness: Endianness | None = None,
        use_version_2: bool | None = None,
    ) -> bytes:
        if buffer is None and endianness in (None, Endianness.Little) and not use_version_2:
            return encode(self)
        return IdlStruct.serialize(self, buffer, endianness, use_version_2)

    def deserialize(
        klass: type[IdlStruct], data: bytes, has_header: bool = True, use_version_2: bool | None = None
    ) -> Any:
        try:
            if has_header and data[:2] == HEADER[:2]:
                return decode(klass, data)
            if has_header and len(data) < len(HEADER):  # the binding reads b"" as a default sample
                raise MalformedSample("no encapsulation header")
            return binding_deserialize(klass, data, has_header, use_version_2)
        except Exception:  # any undecodable sample, whichever codec read it
            sample = klass()
            setattr(sample, _MALFORMED, True)
            return sample

    cls.serialize = serialize  # type: ignore[method-assign]
    cls.deserialize = classmethod(deserialize)  # type: ignore[method-assign,assignment]
    return cls
