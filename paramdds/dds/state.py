"""``ParameterEvents`` samples straight between bytes and core values: the hot paths of
a monitor (decoding thousands at once) and a server (publishing every change).

A monitor that joins a system of 100 nodes receives 5,000+ state samples at once.
Through the generated codec (:mod:`.cdr`) each one became three wire objects and
six lists, then core values (:mod:`.convert`): ~14 µs a sample in a real monitor.

Almost every state sample has one shape: a parameter with a scalar value (bool,
integer, double, string), every array empty and no descriptor beyond its name and
type (see :func:`.convert.state_descriptor_to_wire`), or a node's presence (no
value at all). :func:`decode_state` reads exactly that shape in one pass, into a
:class:`StateSample` of core values (~2.4 µs). Any other bytes (arrays, a
descriptor, an older or newer writer, another encoding, damage) go through the
generated codec and :mod:`.convert`, which define the result: the fast path only
ever returns what that slower path would (``tests/dds/test_state.py`` checks this
on generated and damaged samples). :func:`encode_state` is the reverse for a
server's parameter samples of that shape: the same bytes as the generated encoder
of the wire sample, without building it.

Layout of the fast shape (plain XCDR1 little endian, every struct ``@final``: no
headers inside; each member aligned to its size, up to 8, from the end of the
encapsulation header)::

    header | node_id | name | kind | pad to 8 | revision | Time{sec nanosec}
    | ParameterValue{type bool pad(6) int64 double string 5 x empty sequence}
    | descriptor: empty sequence | host | pid | parameter_count
"""

from __future__ import annotations

import struct
from typing import Any, NamedTuple

from ..core.descriptors import ParameterDescriptor
from ..core.values import NOT_SET, ParameterType, ParameterValue
from ..errors import ParamddsError
from . import types as wire
from .cdr import HEADER, MalformedSample, encode_str, is_malformed
from .convert import is_plain, state_descriptor_from_wire, value_from_wire

__all__ = ["StateKey", "StateSample", "decode_key", "decode_state", "decode_state_slowly", "encode_state"]


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


class StateKey(NamedTuple):
    """The instance of a sample without data (disposed, or no writers left)."""

    node_id: str
    name: str


_TYPES = tuple(ParameterType)
_U32 = struct.Struct("<I")
_unpack_u32 = _U32.unpack_from
# from the revision (8-aligned) to the string value's length: revision, Time {sec nanosec},
# ParameterValue {type bool (pad to 8) int64 double}, length of string_value
_MIDDLE = struct.Struct("<qiIB?6xqdI")
_unpack_middle = _MIDDLE.unpack_from
_unpack_tail = struct.Struct("<iI").unpack_from  # pid, parameter_count
# the rest of the value (4 empty sequences after the string's), and no descriptor
_PLAIN_TAIL = bytes(24)
_NO_HOST_PID_COUNT = bytes.fromhex("01000000000000000000000000000000")  # "", 0, 0
_PAD = tuple(bytes(n) for n in range(8))  # _PAD[(4 - n) & 7]: aligns offset n to 8 after the header


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
        s.node_id, s.name, s.kind, s.revision, stamp, value, descriptor, s.host, s.pid, s.parameter_count
    )


def decode_key(data: bytes) -> StateKey:
    """The key of a sample without data, as ``DataReader.take`` hands it over."""
    try:
        key: Any = wire.ParameterEvent.deserialize_key(data)
        return StateKey(key.node_id, key.name)
    except Exception as exc:  # the binding's decoder raises anything on bytes that are not a key
        raise MalformedSample(f"not a ParameterEvents key: {exc}") from exc


def _decode_fast(buf: bytes) -> StateSample | None:
    """The common shape, or None (then the slow path decides, also whether it is malformed)."""
    try:
        if not buf.startswith(HEADER[:2]):
            return None
        end = len(buf)
        node_id, pos = _key_string(buf, 4, end)
        pos += -pos & 3
        name, pos = _key_string(buf, pos, end)
        kind = buf[pos]  # one byte, straight after the name
        pos += 1
        pos += (4 - pos) & 7
        revision, sec, nanosec, t, b, i, d, n = _unpack_middle(buf, pos)
        pos += _MIDDLE.size
        e = pos + n
        if kind > 1 or t > 4 or n == 0 or e > end or buf[e - 1] != 0:
            return None
        s = buf[pos : e - 1].decode()
        pos = e + (-e & 3)
        if buf[pos : pos + 24] != _PLAIN_TAIL:
            return None
        pos += 24
        (n,) = _unpack_u32(buf, pos)  # host
        e = pos + 4 + n
        if n == 0 or e > end or buf[e - 1] != 0:
            return None
        host = buf[pos + 4 : e - 1].decode()
        pos = e + (-e & 3)
        pid, count = _unpack_tail(buf, pos)  # bytes after these are padding: ignored, as the codec does
    except (struct.error, IndexError, UnicodeDecodeError):
        return None
    ptype = _TYPES[t]
    value = NOT_SET if t == 0 else ParameterValue(ptype, b if t == 1 else i if t == 2 else d if t == 3 else s)
    stamp = sec + nanosec / 1e9
    return StateSample(node_id, name, kind, revision, stamp, value, _plain(name, ptype), host, pid, count)


def _key_string(buf: bytes, pos: int, end: int) -> tuple[str, int]:
    """A ``bounded_str[255]`` at ``pos`` (4-aligned); the string, the offset after it."""
    (n,) = _unpack_u32(buf, pos)
    e = pos + 4 + n
    if n == 0 or n > 256 or e > end or buf[e - 1] != 0:
        raise IndexError("not a key string")
    return buf[pos + 4 : e - 1].decode(), e


_plain_descriptors: dict[tuple[str, ParameterType], ParameterDescriptor] = {}
_PLAIN_DESCRIPTORS_MAX = 65_536


def _plain(name: str, ptype: ParameterType) -> ParameterDescriptor:
    """``ParameterDescriptor(name, ptype)``, shared: descriptors are immutable, and most nodes
    of a system have the same few parameter names (creating one costs ~1 µs, a third of a sample)."""
    key = (name, ptype)
    d = _plain_descriptors.get(key)
    if d is None:
        if len(_plain_descriptors) >= _PLAIN_DESCRIPTORS_MAX:
            _plain_descriptors.clear()  # a bound, not a policy: any entry is as good as a new one
        d = _plain_descriptors[key] = ParameterDescriptor(name, ptype)
    return d


def encode_state(
    node_id: str,
    name: str,
    revision: int,
    sec: int,
    nanosec: int,
    value: ParameterValue,
    d: ParameterDescriptor,
) -> bytes | None:
    """A parameter's state sample of the common shape, ready to write; None for any other
    (then build the wire sample and let the generated encoder write it)."""
    t = int(value.type)
    if not 1 <= t <= 4 or not is_plain(d, value):
        return None
    if len(node_id.encode()) > 255 or len(name.encode()) > 255:
        return None  # over the bound: the generated encoder raises the error
    v = value.value
    s = v.encode() if isinstance(v, str) else b""
    body = len(s) + 1
    out = bytearray(HEADER)
    encode_str(out, node_id)
    encode_str(out, name)
    out.append(wire.EVENT_PARAMETER)
    out += _PAD[(4 - len(out)) & 7]
    try:
        out += _MIDDLE.pack(
            revision,
            sec,
            nanosec,
            t,
            v if t == 1 else False,
            v if t == 2 else 0,
            v if t == 3 else 0.0,
            body,
        )
    except struct.error:
        return None  # out of range: the generated encoder raises the error
    out += s + b"\0" + _PAD[-body & 3] + _PLAIN_TAIL + _NO_HOST_PID_COUNT
    return bytes(out)
