"""A fast XCDR2 codec for the wire types, byte-identical to cyclonedds-python's.

cyclonedds-python encodes and decodes a sample by walking a generic machine
member by member through a ``Buffer`` object: ~90 µs to decode one state sample
here, most of a monitor's time. Every wire type is a small, fixed ``@appendable``
struct, so this module writes straight-line functions per struct instead (Python
source from the templates below, compiled on first use, as ``dataclasses`` does
for ``__init__``): an encoder, a fast decoder that assumes every member is present
and reads runs of fixed-size members at once, and a careful decoder, member by
member, that the fast one falls back to on any failure. ~11 µs per state sample.
``source(cls)`` shows the generated code. (Two threads compiling the same struct
at once both get correct functions; one set is kept.)

Scope: little-endian delimited XCDR2 (``D_CDR2_LE``, the encoding every
``@appendable`` type gets from this binding on the machines we ship to).
Anything else (big-endian peers, XCDR1, a caller passing a ``Buffer``) goes to
the binding, so behaviour never depends on this module's coverage.
``tests/dds/test_cdr.py`` checks, with generated samples, that both codecs
write the same bytes and read each other's output.

Appendable rules: each struct starts with a DHEADER (its size in bytes).
Members past that size keep their defaults (an older writer); bytes after the
last member we know are skipped (a newer writer).

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

from ._binding import Endianness, binding_deserialize

HEADER = b"\x00\x09\x00\x00"  # D_CDR2 little-endian, no options
_MALFORMED = "_paramdds_malformed"

# annotation -> struct code; XCDR2 aligns every member of 4 bytes or more to 4
_CODES = {"uint8": "B", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float64": "d"}


class MalformedSample(ValueError):
    """The bytes are not a valid encoding of the type."""


def is_malformed(sample: object) -> bool:
    """Whether a sample taken from a reader could not be decoded (see the module doc)."""
    return bool(getattr(sample, _MALFORMED, False))


# ---- code templates, one per kind of member -----------------------------------------------------
#
# Decoding reads ``buf`` (bytes) at ``pos`` and must stay within ``end``, the end of the
# enclosing struct; encoding appends to ``out`` (a bytearray whose offset 0 is the start
# of the encapsulation header, so alignment is on len(out)). ``{v}`` is the member's
# variable, ``{c}`` a struct code, ``{b}`` a bound (``{bcheck}`` its test, empty when
# unbounded; lines marked ``[bounded]`` are dropped then), ``{f}`` a nested function's name.

_ALIGN = "pos += -pos & 3"
_OUT_ALIGN = "out += PAD[-len(out) & 3]"

_DECODE = {
    "byte": ["{v} = buf[pos]", "pos += 1"],
    "bool": ["{v} = buf[pos] != 0", "pos += 1"],
    "fixed": [_ALIGN, "({v},) = unpack_{c}(buf, pos)", "pos += {size}"],
    "string": [
        _ALIGN,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "e = pos + n",
        "if n == 0{bcheck} or e > end or buf[e - 1] != 0:",
        "    raise MalformedSample('bad string length, bound or terminator')",
        "{v} = buf[pos : e - 1].decode()",
        "pos = e",
    ],
    "bytes": [  # sequence<uint8> and sequence<bool>: one byte each; most sequences are empty
        _ALIGN,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "if n:",
        "    e = pos + n",
        "    if e > end{bcheck}:",
        "        raise MalformedSample('sequence past its bound or the struct')",
        "    {v} = {convert}",
        "    pos = e",
        "else:",
        "    {v} = []",
    ],
    "array": [  # sequence of 4- or 8-byte primitives
        _ALIGN,
        "(n,) = unpack_I(buf, pos)",
        "pos += 4",
        "if n:",
        "    e = pos + n * {size}",
        "    if e > end{bcheck}:",
        "        raise MalformedSample('sequence past its bound or the struct')",
        "    {v} = list(unpack_from('<%d{c}' % n, buf, pos))",
        "    pos = e",
        "else:",
        "    {v} = []",
    ],
    "delimited": [  # sequence of strings or structs: DHEADER, length, elements
        _ALIGN,
        "(size, n) = unpack_II(buf, pos)",
        "e = pos + 4 + size",
        "pos += 8",
        "if 4 * n > size or e > end{bcheck}:",  # every element takes at least 4 bytes
        "    raise MalformedSample('sequence past its bound or the struct')",
        "{v} = []",
        "for _ in range(n):",
        "    x, pos = {f}(buf, pos, e)",
        "    {v}.append(x)",
        "pos = e",
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
        _OUT_ALIGN,
        "out += pack_I(len(data) + 1)",
        "out += data",
        "out.append(0)",
    ],
    # most sequences are empty (a value uses one of its five): one append for those
    "bytes": [
        "[bounded]check_count(len({v}), {b})",
        _OUT_ALIGN,
        "if {v}:",
        "    out += pack_I(len({v}))",
        "    out += bytes({convert})",
        "else:",
        "    out += EMPTY",
    ],
    "array": [
        "[bounded]check_count(len({v}), {b})",
        _OUT_ALIGN,
        "out += pack('<I%d{c}' % len({v}), len({v}), *{v}) if {v} else EMPTY",
    ],
    "delimited": [
        "[bounded]check_count(len({v}), {b})",
        _OUT_ALIGN,
        "if {v}:",
        "    {v}_at = len(out)",
        "    out += pack_II(0, len({v}))",
        "    for x in {v}:",
        "        {f}(out, x)",
        "    pack_into_I(out, {v}_at, len(out) - {v}_at - 4)",
        "else:",
        "    out += EMPTY_DELIMITED",
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
        fields = {"v": var, "c": self.code, "size": size, "b": self.bound, "bmsg": bmsg, "f": fn}
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
        return _Member("byte") if meta == "uint8" else _Member("fixed", _CODES[meta])
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
            return _Member("delimited", bound=bound, nested=element.nested)
    raise TypeError(f"no fast codec for {hint!r}")  # a new kind of member: extend this module


def check_count(n: int, bound: int) -> None:
    if n > bound:
        raise ValueError(f"sequence of {n} elements is longer than its bound of {bound}")


def _str_decode(buf: bytes, pos: int, end: int) -> tuple[str, int]:
    """A string as a sequence element."""
    pos += -pos & 3
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
    **{f"unpack_{c}": struct.Struct("<" + c).unpack_from for c in ("I", "II", *_CODES.values())},
    **{f"pack_{c}": struct.Struct("<" + c).pack for c in ("I", "II", *_CODES.values())},
    "pack_into_I": struct.Struct("<I").pack_into,
    "PAD": (b"", b"\0", b"\0\0", b"\0\0\0"),
    "EMPTY": b"\0\0\0\0",  # a sequence's length, 0
    "EMPTY_DELIMITED": b"\4\0\0\0\0\0\0\0",  # DHEADER 4 (just the length), length 0
    "MalformedSample": MalformedSample,
    "check_count": check_count,
    "decode_str": _str_decode,
    "fast_str": _str_decode,
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
        fast, encode = _fast_decoder_and_encoder(name, members, packers)
        source = "\n\n\n".join("\n".join(f) for f in (_careful_decoder(name, members), fast, encode))
        namespace = dict(_BASE_NAMESPACE, cls=cls, **functions, **packers)
        exec(compile(source + "\n", f"<paramdds.dds.cdr {name}>", "exec"), namespace)
        _compiled[cls] = _Functions(
            namespace[f"decode_{name}"], namespace[f"fast_{name}"], namespace[f"encode_{name}"], source + "\n"
        )
    compiled = _compiled[cls]
    functions.update(
        {f"decode_{name}": compiled.decode, f"fast_{name}": compiled.fast, f"encode_{name}": compiled.encode}
    )
    return name


_HEAD = [  # every struct decoder starts here: align, read the DHEADER, bound the struct
    "    pos += -pos & 3",
    "    (size,) = unpack_I(buf, pos)",
    "    pos += 4",
    "    if pos + size > end:",
    "        raise MalformedSample('struct past its container')",
    "    end = pos + size",
]
_TAIL = ["    if pos > end:", "        raise MalformedSample('members past the struct size')"]


def _careful_decoder(name: str, members: list[tuple[str, _Member]]) -> list[str]:
    """Member by member, stopping where an older writer's struct ends."""
    lines = [f"def decode_{name}(buf, pos, end):", *_HEAD]
    done: list[str] = []
    for i, (field, member) in enumerate(members):
        lines.append(f"    if pos >= end:  # an older writer: {field} and later keep their defaults")
        lines.append(f"        return cls({', '.join(done)}), end")
        lines += ["    " + line for line in member.lines(_DECODE, f"m{i}", f"decode_{member.nested}")]
        done.append(f"m{i}")
    return [*lines, *_TAIL, f"    return cls({', '.join(done)}), end"]


def _fast_decoder_and_encoder(
    name: str, members: list[tuple[str, _Member]], packers: dict[str, Any]
) -> tuple[list[str], list[str]]:
    """Every member present (the common case), runs of fixed-size members read and written at once.

    Where the offset modulo 4 is known (from the struct start, up to the first
    string or struct), a run of fixed-size members becomes one ``struct`` format
    with its padding spelled out (``<B?xxqd`` for ParameterValue's first four).
    """
    dec = [f"def fast_{name}(buf, pos, end):", *_HEAD]
    enc = [
        f"def encode_{name}(out, obj):",
        f"    {_OUT_ALIGN}",
        "    at = len(out)",
        "    out += b'\\0\\0\\0\\0'",
    ]
    phase: int | None = 0  # the offset modulo 4, when known
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
        size = (
            1
            if member.kind in ("byte", "bool")
            else struct.calcsize("<" + member.code)
            if member.kind == "fixed"
            else 0
        )
        if size and phase is None and size == 1:  # offset unknown: a lone byte needs no alignment
            dec += ["    " + line for line in member.lines(_DECODE, var, "")]
            enc += [f"    {var} = obj.{field}", *("    " + line for line in member.lines(_ENCODE, var, ""))]
        elif size:
            if phase is None:  # align at run time; from here the offset is known
                flush()
                dec.append(f"    {_ALIGN}")
                enc.append(f"    {_OUT_ALIGN}")
                phase = 0
            pad = -phase % 4 if size > 1 else 0
            run.append((var, field, "x" * pad + ("?" if member.kind == "bool" else member.code or "B")))
            phase = (phase + pad + size) % 4
        else:
            flush()
            dec += ["    " + line for line in member.lines(_DECODE, var, f"fast_{member.nested}")]
            enc += [
                f"    {var} = obj.{field}",
                *("    " + line for line in member.lines(_ENCODE, var, f"encode_{member.nested}")),
            ]
            phase = 0 if member.kind == "array" else None
    flush()
    dec += [*_TAIL, f"    return cls({', '.join(f'm{i}' for i in range(len(members)))}), end"]
    enc.append("    pack_into_I(out, at, len(out) - at - 4)")
    return dec, enc


class _Functions(NamedTuple):
    decode: Any  # (buf, pos, end) -> (sample, end): careful, raises MalformedSample
    fast: Any  # the same assuming every member is present; on any failure, use decode
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
    """Decode a sample with its encapsulation header; raises MalformedSample."""
    functions = _codec(cls)
    try:
        return functions.fast(data, 4, len(data))[0]
    except (struct.error, ValueError, IndexError):  # incl. MalformedSample and UnicodeDecodeError
        pass  # an older writer, or bytes that are not a sample: the careful decoder tells which
    try:
        return functions.decode(data, 4, len(data))[0]
    except MalformedSample:
        raise
    except (struct.error, ValueError, IndexError) as exc:
        raise MalformedSample(str(exc)) from exc


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
        if buffer is None and endianness in (None, Endianness.Little) and use_version_2 is not False:
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
