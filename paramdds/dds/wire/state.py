"""``ParameterEvents`` samples straight between bytes and core values: the hot paths of
a monitor (decoding thousands at once) and a server (publishing every change).

A monitor that joins a fleet of 10,000 nodes x 20 parameters receives 200,000 state
samples at once. Through the generated codec (:mod:`.cdr`) each one becomes a tree of
wire objects and lists, then core values (:mod:`.convert`): ~10 µs a realistic sample
in a tight loop, ~23 µs in a live monitor. :func:`decode_state` reads any well-formed
sample in one pass instead, into a :class:`StateSample` of core values (~3 µs, ~5 µs
live); :func:`encode_state` writes a server's parameter sample without building the
wire objects (~3 µs instead of ~10).

**The rule: the fast path only returns what the slow one would.** The generated codec
and :mod:`.convert` (:func:`decode_state_slowly`) define the result. The fast reader
returns an equal object of the same types, or None for anything it does not read in
full (big endian, XCDR2, an unknown type byte, a sequence over its bound or beside the
value's own, truncated or damaged bytes); then the slow path decides, and raises
:class:`MalformedSample` for bytes that are no sample. The fast writer returns the
generated encoder's bytes, or None (then the caller builds the wire sample).
``tests/dds/test_state.py`` checks both on generated, damaged and real-world samples.

Layout (plain XCDR1 little endian, every struct ``@final``: no headers inside; each
primitive aligned to its size, up to 8, from the end of the encapsulation header)::

    header | node_id | name | kind | pad to 8 | revision | Time{sec nanosec}
    | ParameterValue{type bool pad(6) int64 double string 5 sequences}
    | descriptor: sequence of 0 or 1 ParameterDescriptor | host | pid | parameter_count
    | pad to 8 | incarnation | who | verified | via

The value and descriptor readers and writers live in :mod:`.state_cdr`. Descriptors
repeat (a fleet runs the same node types, a server republishes a parameter on every
set) and are immutable, so both directions keep them in bounded caches: decoded ones
kept by their exact bytes, one cache per offset modulo 8 (XCDR1 padding is relative to
the stream), found through their first bytes (a descriptor's length is only known once
it is read: the sample is compared with the few decoded ones that start as it does);
encoded ones keyed on the descriptor and that offset. The tail after the descriptor
(``host pid parameter_count incarnation who verified via``) is read in three parts: the
incarnation in place (a node's, new on every start of its server), and the parts around
it each kept by their bytes: host, pid and count (a parameter's sample has none: "", 0, 0;
a presence sample has its server process's), and the blame (one per author and path).
Nothing kept grows with the nodes or their server lives: kept whole, with the
incarnation, the tail was an entry per node, server life and author that outlived its
life, and a long-lived monitor under churn grew by them. The encoder keeps the blame
bytes it writes. Scalar values are shared the same way, keyed on their
bytes: a live monitor spent a sixth of its sync in the garbage collector, walking
200,000 new value objects that mostly repeat.
"""

from __future__ import annotations

import math
import struct
from typing import Any, NamedTuple

from ...core.descriptors import ParameterDescriptor
from ...core.values import NOT_SET, ParameterType, ParameterValue
from ...errors import ParamddsError
from . import types as wire
from .cdr import HEADER, MalformedSample, encode_str, is_malformed
from .convert import state_descriptor_from_wire, value_from_wire
from .state_cdr import (
    BOOL,
    DOUBLE,
    INTEGER,
    REFUSED,
    STRING,
    UNWRITTEN,
    NotFast,
    finish_value,
    read_descriptor,
    read_str,
    write_arrays,
    write_descriptor,
)

__all__ = [
    "StateKey",
    "StateSample",
    "cache_sizes",
    "decode_key",
    "decode_state",
    "decode_state_slowly",
    "encode_key",
    "encode_state",
]


class StateSample(NamedTuple):
    """One ``ParameterEvents`` sample in core terms (a presence sample's descriptor is only its name)."""

    node_id: str
    name: str
    kind: int
    revision: int
    stamp: float  # seconds since the epoch
    value: ParameterValue
    descriptor: ParameterDescriptor
    host: str
    pid: int
    parameter_count: int
    incarnation: int  # the server's for this node (new on every start); 0 from a writer without one
    # who made the change this sample carries, whether the node verified it, through what
    # ("cli", "api", ...): "" from a writer that keeps no blame (and on presence samples)
    who: str = ""
    verified: bool = False
    via: str = ""


class StateKey(NamedTuple):
    """The instance of a sample without data (disposed, or no writers left)."""

    node_id: str
    name: str


_TYPES = tuple(ParameterType)  # index == type byte
_CDR_LE = HEADER[:2]  # the encapsulation kind: plain XCDR1, little endian
_new_tuple = tuple.__new__
_PRESENCE = wire.EVENT_PRESENCE
_U32 = struct.Struct("<I")
_unpack_u32 = _U32.unpack_from
# from the revision (8-aligned) to the string value's length: revision, Time {sec nanosec},
# ParameterValue {type bool (pad to 8) int64 double}, length of string_value
_MIDDLE = struct.Struct("<qiIB?6xqdI")
_unpack_middle = _MIDDLE.unpack_from
_TAIL = struct.Struct("<iI")  # pid, parameter_count
_U64 = struct.Struct("<Q")  # the incarnation (8-aligned)
_unpack_u64 = _U64.unpack_from
_EMPTY = bytes(4)  # a sequence's length, 0: no descriptor
_NO_ARRAYS = bytes(20)  # a value's five sequences, all empty
_NO_HOST_PID_COUNT = bytes.fromhex("01000000000000000000000000000000")  # "", 0, 0
_PAD = tuple(bytes(n) for n in range(8))  # _PAD[(4 - n) & 7]: aligns offset n to 8 after the header
# The descriptor caches: entries each, and the longest descriptor kept (real ones take
# ~150 bytes, the longest of four generate_parameter_library specs ~900): at most ~8 MB.
_CACHE_MAX = 8_192
_CACHED_BYTES_MAX = 1_024
_PLAIN_MAX = 65_536  # (name, type) pairs: small entries
# Scalar values by their bytes: a fleet's nodes mostly hold the same few values, and sharing
# them spares the allocations (and garbage-collector passes) of 200,000 new objects at once.
# ~170 B an entry. 1,024 hold a fleet's common values (the 29 real parameter files of
# shared/realworld hold 363 distinct scalars in all) in ~0.17 MB. A bound of 8,192
# (~1.4 MB) was a long-lived monitor's memory growing for half an hour under the soak's stream
# of new values, +4.2 % after a warm-up where 1,024 grew +0.6 % (docs/decisions.md).
_values: dict[bytes, ParameterValue] = {}
_VALUES_MAX = 1_024
_VALUE_KEY_MAX = 96  # bytes: a scalar's 28 and a short string
_VALUE_AT = 16  # from the revision to the value: revision (8), Time (8)
# The tail after the descriptor (host pid parameter_count incarnation who verified via), read
# in three parts (see the module doc): the incarnation in place, the parts before and after it
# kept by their bytes, an entry per server process and per author. Kept whole, the tails were
# an entry per node, server life and author (~450 B) outliving the life: ~20,000 an hour for a
# monitor under the soak's churn (~9 MB), below a bound of 65,536 it never reached.
# A tail whose host is "" (a parameter's sample), starting at an offset of 0 or 4 modulo 8:
# the host's length and terminator, pid, parameter_count, the incarnation (8-aligned)
_SHORT_TAILS = (struct.Struct("<IB3xiI4xQ"), struct.Struct("<IB3xiIQ"))
_Head = tuple[str, int, int]
_heads: dict[bytes, _Head] = {}  # host pid parameter_count, by their bytes
_HEADS_MAX = 4_096
_Blame = tuple[str, bool, str]
_read_blames: dict[bytes, _Blame] = {}  # who verified via (and any padding), by their bytes
_READ_BLAMES_MAX = 4_096
_TAIL_KEY_MAX = 256
# the blame the encoder writes after the incarnation, by (who, verified, via)
_blame_bytes: dict[tuple[str, bool, str], bytes] = {}
_last_blame: tuple[str, bool, str, bytes] = ("", False, "", b"\1\0\0\0\0\0\0\0\1\0\0\0\0\0\0\0")
_BLAMES_MAX = 4_096
# A descriptor's length is known once it is read: the ones decoded from the same first
# bytes (at the same offset modulo 8) are compared with the sample's, a few at most
_PROBE = 24
_SEEN_PER_PROBE = 4


def decode_state(data: bytes) -> StateSample:
    """The sample ``data`` (with its encapsulation header) in core terms; MalformedSample if it is none."""
    fast = _decode_fast(data)
    return fast if fast is not None else decode_state_slowly(data)


def decode_state_slowly(data: bytes) -> StateSample:
    """The generated codec and :mod:`.convert`: the reference :func:`decode_state` must agree with."""
    s = wire.ParameterEvent.deserialize(data)
    if is_malformed(s):
        raise MalformedSample("not a ParameterEvents sample")
    try:  # a foreign writer's unknown type byte, in the value or the descriptor
        value = value_from_wire(s.value)
        descriptor = state_descriptor_from_wire(s.descriptor, s.name, value)
    except ParamddsError as exc:
        raise MalformedSample(str(exc)) from exc
    stamp = s.stamp.sec + s.stamp.nanosec / 1e9
    return StateSample(
        s.node_id,
        s.name,
        s.kind,
        s.revision,
        stamp,
        value,
        descriptor,
        s.host,
        s.pid,
        s.parameter_count,
        s.incarnation,
        s.who,
        s.verified,
        s.via,
    )


def encode_key(node_id: str, name: str) -> bytes:
    """The key of an instance as the binding's ``serialize_key`` writes it (padded to 4), for
    an unregister or dispose without building a wire sample (a server closing 1,000 nodes
    unregisters 21,000 instances)."""
    out = bytearray(HEADER)
    encode_str(out, node_id)
    encode_str(out, name)
    out += bytes(-len(out) & 3)
    return bytes(out)


def decode_key(data: bytes) -> StateKey:
    """The key of a sample without data, as ``DataReader.take`` hands it over."""
    try:
        key: Any = wire.ParameterEvent.deserialize_key(data)
        return StateKey(key.node_id, key.name)
    except Exception as exc:  # the binding's decoder raises anything on bytes that are not a key
        raise MalformedSample(f"not a ParameterEvents key: {exc}") from exc


def _decode_fast(buf: bytes) -> StateSample | None:
    """Any well-formed little-endian XCDR1 sample, or None (then the slow path decides,
    also whether it is malformed)."""
    try:
        if not buf.startswith(_CDR_LE):
            return None
        end = len(buf)
        node_id, pos = _key_string(buf, 4, end)
        name, pos = _key_string(buf, pos + (-pos & 3), end)
        kind = buf[pos]  # one byte, straight after the name
        if kind > _PRESENCE:
            return None
        pos += 1
        pos += (4 - pos) & 7
        revision, sec, nanosec, t, b, i, d, n = _unpack_middle(buf, pos)
        start = pos + _VALUE_AT  # the value's first byte
        pos += _MIDDLE.size
        e = pos + n
        after = e + (-e & 3)  # the string's end, aligned for the sequences after it
        if t <= STRING and buf[after : after + 20] == _NO_ARRAYS:
            # the most common values, inline: a scalar or none, no arrays
            if n == 0 or e > end or buf[e - 1] != 0:
                return None
            key = buf[start:e]  # every byte the value is read from: equal bytes, equal value
            value = _values.get(key)
            if value is None:
                s = buf[pos : e - 1].decode()
                x = b if t == 1 else i if t == 2 else d if t == 3 else s
                value = NOT_SET if t == 0 else ParameterValue(_TYPES[t], x)
                if len(key) <= _VALUE_KEY_MAX:
                    _bounded(_values, _VALUES_MAX)[key] = value
            pos = after + 20
        else:
            value, pos = finish_value(buf, pos, end, t, b, i, d, n)
            pos += -pos & 3
        if buf[pos : pos + 4] == _EMPTY:  # only the name and the value's type: see convert.is_plain
            descriptor = _plain(name, value.type)
            pos += 4
        else:
            descriptor, pos = _described(buf, pos, end)
        pos += -pos & 3  # a descriptor may end unaligned (on a string array)
        short = _SHORT_TAILS[pos & 4 and 1]
        n, z, pid, count, incarnation = short.unpack_from(buf, pos)
        if n == 1 and z == 0:  # no host (a parameter's sample): the incarnation is read already
            host = ""
            pos += short.size
        else:
            at = pos + 4 + n  # the host's end
            at += (-at & 3) + 8
            key = buf[pos:at]
            head = _heads.get(key)
            if head is None:
                head = _head(key)
            host, pid, count = head
            pos = at + ((4 - at) & 7)  # the incarnation: 8-aligned after the header
            (incarnation,) = _unpack_u64(buf, pos)
            pos += 8
        key = buf[pos:]
        blame = _read_blames.get(key)
        if blame is None:
            blame = _blame_read(key)
    except REFUSED:
        return None
    stamp = sec + nanosec / 1e9
    fields = (node_id, name, kind, revision, stamp, value, descriptor, host, pid, count, incarnation)
    return _new_tuple(StateSample, fields + blame)  # StateSample(*fields, *blame) without its Python __new__


def _key_string(buf: bytes, pos: int, end: int) -> tuple[str, int]:
    """A ``bounded_str[255]`` at ``pos`` (4-aligned); the string, the offset after it."""
    (n,) = _unpack_u32(buf, pos)
    e = pos + 4 + n
    if n == 0 or n > 256 or e > end or buf[e - 1] != 0:
        raise NotFast("not a key string")
    return buf[pos + 4 : e - 1].decode(), e


def _head(data: bytes) -> _Head:
    """host, pid, parameter_count from their bytes (the host's string, padding, two 4-byte
    numbers); kept by those bytes."""
    end = len(data)
    host, pos = read_str(data, 0, end)
    pos += -pos & 3
    pid, count = _TAIL.unpack_from(data, pos)
    result = (host, pid, count)
    if end <= _TAIL_KEY_MAX:
        _bounded(_heads, _HEADS_MAX)[data] = result
    return result


def _blame_read(data: bytes) -> _Blame:
    """who, verified, via from the bytes after the incarnation (which start 4-aligned); bytes
    after ``via`` are padding, ignored as the codec does. Kept by those bytes: wherever they
    come they decode the same."""
    end = len(data)
    who, pos = read_str(data, 0, end)
    verified = data[pos] != 0
    via, _ = read_str(data, pos + 1, end)
    result = (who, verified, via)
    if end <= _TAIL_KEY_MAX:
        _bounded(_read_blames, _READ_BLAMES_MAX)[data] = result
    return result


# one cache per offset modulo 8: by a descriptor's first bytes, the descriptors decoded
# from bytes that start so (their bytes, the descriptor), a few at most
_Decoded = tuple[tuple[bytes, ParameterDescriptor], ...]
_decoded: tuple[dict[bytes, _Decoded], ...] = tuple({} for _ in range(8))


def _described(buf: bytes, pos: int, end: int) -> tuple[ParameterDescriptor, int]:
    """The descriptor sequence at ``pos`` (not empty) and the offset after it, decoded once
    per distinct bytes and alignment (see the module doc)."""
    decoded = _decoded[pos & 7]
    probe = buf[pos : pos + _PROBE]
    seen = decoded.get(probe, ())
    for data, descriptor in seen:
        if buf.startswith(data, pos):  # the same bytes at the same alignment: the same descriptor
            return descriptor, pos + len(data)
    (count,) = _unpack_u32(buf, pos)
    if count != 1:
        raise NotFast("a descriptor sequence over its bound of 1")
    descriptor, after = read_descriptor(buf, pos + 4, end)
    if after - pos <= _CACHED_BYTES_MAX:
        entry = (buf[pos:after], descriptor)
        _bounded(decoded, _CACHE_MAX)[probe] = (entry, *seen[: _SEEN_PER_PROBE - 1])
    return descriptor, after


def cache_sizes() -> dict[str, int]:
    """The entries each cache of this module holds now: what a long-lived reader keeps here."""
    return {
        "values": len(_values),
        "heads": len(_heads),
        "blames": len(_read_blames),
        "descriptors": sum(len(d) for d in _decoded),
        "plain": len(_plain_descriptors),
        "encoded": len(_encoded),
        "written_blames": len(_blame_bytes),
    }


def _bounded(cache: dict[Any, Any], limit: int) -> dict[Any, Any]:
    """``cache``, emptied first when full: a bound, not a policy (any entry is as good as a new one)."""
    if len(cache) >= limit:
        cache.clear()
    return cache


_plain_descriptors: dict[tuple[str, ParameterType], ParameterDescriptor] = {}


def _plain(name: str, ptype: ParameterType) -> ParameterDescriptor:
    """``ParameterDescriptor(name, ptype)``, shared: descriptors are immutable, and most nodes
    of a system have the same few parameter names (creating one costs ~1 µs, a third of a sample)."""
    key = (name, ptype)
    d = _plain_descriptors.get(key)
    if d is None:
        d = _bounded(_plain_descriptors, _PLAIN_MAX)[key] = ParameterDescriptor(name, ptype)
    return d


def encode_state(
    node_id: str,
    name: str,
    revision: int,
    sec: int,
    nanosec: int,
    value: ParameterValue,
    d: ParameterDescriptor,
    incarnation: int = 0,
    who: str = "",
    verified: bool = False,
    via: str = "",
) -> bytes | None:
    """A parameter's state sample, ready to write: the generated encoder's bytes for the wire
    sample of these arguments; None where that encoder would fail (a key over its bound, a
    number out of range, text that is no Unicode), so the caller builds the wire sample and
    gets its error."""
    t, x = int(value.type), value.value
    try:
        key = node_id.encode(), name.encode()
        if len(key[0]) > 255 or len(key[1]) > 255:
            return None  # over the bound: the generated encoder raises the error
        s = x.encode() if isinstance(x, str) else b""
        out = bytearray(HEADER)
        encode_str(out, node_id)
        encode_str(out, name)
        out.append(wire.EVENT_PARAMETER)
        out += _PAD[(4 - len(out)) & 7]
        out += _MIDDLE.pack(
            revision,
            sec,
            nanosec,
            t,
            t == BOOL and bool(x),
            x if t == INTEGER else 0,
            x if t == DOUBLE else 0.0,
            len(s) + 1,
        )
        out += s
        out.append(0)
        write_arrays(out, t, x)
        out += _PAD[-len(out) & 3]
        out += _EMPTY if _is_plain(d, value) else _descriptor_bytes(d, len(out) & 7)
    except UNWRITTEN:
        return None  # out of range, not text, no core value: the generated encoder decides
    out += _PAD[-len(out) & 3]  # a descriptor may end unaligned (on a string array)
    out += _NO_HOST_PID_COUNT
    out += _PAD[(4 - len(out)) & 7]
    try:
        out += _U64.pack(incarnation)
        last = _last_blame  # the same objects as the last sample's: every parameter of a change
        if who is last[0] and via is last[2] and verified is last[1]:
            out += last[3]
        else:
            out += _blame(who, verified, via)
    except UNWRITTEN:
        return None  # out of range, not text: the generated encoder raises the error
    return bytes(out)


def _blame(who: str, verified: bool, via: str) -> bytes:
    """The bytes of a blame, from the cache (and kept as the last one written)."""
    global _last_blame
    said = (who, verified, via)
    blame = _blame_bytes.get(said)
    if blame is None:
        blame = _blame_bytes_of(who, verified, via)
        if len(blame) <= _TAIL_KEY_MAX:
            _bounded(_blame_bytes, _BLAMES_MAX)[said] = blame
    _last_blame = (who, verified, via, blame)
    return blame


def _blame_bytes_of(who: str, verified: bool, via: str) -> bytes:
    """who, verified, via after the incarnation (at an offset of 4 modulo 8, like the stream's
    start), padded to 4 as ``DataWriter.write`` pads a sample."""
    if not isinstance(verified, bool):
        raise TypeError("verified is no bool")  # the generated encoder decides what it makes of it
    out = bytearray()
    encode_str(out, who)
    out.append(1 if verified else 0)
    encode_str(out, via)
    out += _PAD[-len(out) & 3]
    return bytes(out)


def _is_plain(d: ParameterDescriptor, value: ParameterValue) -> bool:
    """:func:`.convert.is_plain`, without building a descriptor (~1 µs): a described
    parameter is told by its first non-default field, the rest compared to a shared one."""
    if d.description or d.validators or d.integer_range is not None or d.floating_point_range is not None:
        return False
    return d == _plain(d.name, value.type)


_encoded: dict[tuple[ParameterDescriptor, int], bytes] = {}


def _descriptor_bytes(d: ParameterDescriptor, phase: int) -> bytes:
    """The sequence of the one descriptor ``d``, written at an offset of ``phase`` modulo 8.

    Cached by equality, where equal descriptors have equal bytes; not so for 0.0 and -0.0
    (equal, written differently), so a descriptor holding a negative zero skips the cache."""
    key = (d, phase)
    cacheable = not _has_negative_zero(d)
    data = _encoded.get(key) if cacheable else None
    if data is None:
        out = bytearray(_PAD[phase])
        out += b"\1\0\0\0"
        write_descriptor(out, d)
        data = bytes(out[phase:])
        if cacheable and len(data) <= _CACHED_BYTES_MAX:
            _bounded(_encoded, _CACHE_MAX)[key] = data
    return data


def _has_negative_zero(d: ParameterDescriptor) -> bool:
    fr = d.floating_point_range
    numbers: list[Any] = [] if fr is None else [fr.from_value, fr.to_value, fr.step]
    for validator in d.validators:
        for arg in validator.args:
            if arg.type is ParameterType.DOUBLE:
                numbers.append(arg.value)
            elif arg.type is ParameterType.DOUBLE_ARRAY:
                numbers.extend(arg.value)  # type: ignore[arg-type]
    return any(x == 0 and math.copysign(1.0, x) < 0 for x in numbers)
