"""The one scalar resolver, mirroring ROS 2's own parser (rcl_yaml_param_parser).

ROS 2 types a YAML scalar in ``get_value()`` of rcl_yaml_param_parser/src/parse.c,
not with YAML 1.1's rules. We follow it, so a file means the same here as in ROS:

1. A quoted scalar (``'…'`` or ``"…"``) or one tagged ``!!str`` is a **string**.
   An empty plain scalar (``key:`` with nothing, i.e. YAML null) is an error, as
   in rcl ("No value"); write ``""`` for an empty string.
2. **Bool**, exact spellings only: ``true True TRUE yes Yes YES on On ON y Y`` and
   ``false False FALSE no No NO off Off OFF n N``. (So ``on``/``off``/``y``/``n``
   are booleans, as in rcl; quote them for a string.)
3. **Integer**: C ``strtoll(text, base 0)`` consuming the whole text — decimal,
   ``0x1A`` hexadecimal (26) and **octal with a leading zero** (``010`` is 8).
   A value out of the int64 range is not an integer (ERANGE) and falls through.
4. **Double**: C ``strtod`` consuming the whole text — ``1.5``, ``1e3``, ``.5``,
   ``5.``, ``inf``/``infinity``/``nan`` in any case, hexadecimal ``0x1.8p1``, and
   ``08`` (not octal, so a double 8.0) — plus rcl's YAML forms ``.inf .Inf .INF``
   (with ``+``/``-``) and ``.nan .NaN .NAN`` (no sign). A literal that overflows
   to infinity is a string, as in rcl (ERANGE). One deviation: rcl also refuses
   values that underflow into the subnormal range (glibc sets ERANGE); we keep
   them as doubles so every double survives a dump and reload.
5. Everything else is a **string**: ``abc``, ``1:20`` (PyYAML would read 80),
   ``1_000``, ``0b101``, ``~``, ``null``, ``-.nan``, ``2024-01-01``.

Block scalars (``|``, ``>``) are typed by content like plain ones (rcl only
exempts quoted styles). Our own typed forms are tags:
``!bool_array [...]``, ``!integer_array``, ``!double_array``, ``!string_array``,
``!byte_array [0, 255]`` (the only way to write a byte array and to type an
empty list), and ``!not_set`` (no value). Any other tag is ignored, as rcl ignores
it: ``!!float 1`` is the integer 1 and ``!custom [1, 2]`` an integer array (``!!str``
and quotes still make a string).

Lists are typed by their elements, which must all have one type. Integers and
doubles mixed in one list are an error, as in rcl ("Sequence should be of same
type"): write ``[1.0, 2.5]``. An untagged empty list ``[]`` has no type; it is
an error unless the caller knows the type (a parameter list's ``type:``, a spec ``type:``, a
descriptor), or write ``!double_array []``. Nested lists and maps inside a list
are errors.

Where the type is given explicitly (parameter lists and spec files, ``expected=``), a value
is checked against it: an integer widens to a double (as
:meth:`ParameterValue.coerce` does), and a plain scalar in a string slot is
taken as written (``value: 1.50`` for a ``string`` is ``"1.50"``).
"""

from __future__ import annotations

import math
import re

import yaml

from ..core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from ..errors import FileFormatError, InvalidValueError, ParamddsError
from .base import STR_TAG, Source, compose

__all__ = [
    "ARRAY_TAGS",
    "NOT_SET_TAG",
    "UntypedEmptyList",
    "node_value",
    "parse_cli_value",
    "resolve_plain",
    "typed_value",
]

_TRUE = frozenset(("Y", "y", "yes", "Yes", "YES", "true", "True", "TRUE", "on", "On", "ON"))
_FALSE = frozenset(("N", "n", "no", "No", "NO", "false", "False", "FALSE", "off", "Off", "OFF"))
_YAML_INF_NAN = frozenset(
    (".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF", "+.inf", "+.Inf", "+.INF", "-.inf", "-.Inf", "-.INF")
)
_INT = re.compile(r"([+-]?)(?:0[xX]([0-9a-fA-F]+)|(0[0-7]*)|([1-9][0-9]*))\Z")
_DEC = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
_HEX = re.compile(r"[+-]?0[xX](?:[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)(?:[pP][+-]?[0-9]+)?\Z")
_INF = re.compile(r"([+-]?)(?:inf|infinity)\Z", re.IGNORECASE)
_NAN = re.compile(r"[+-]?nan(?:\([0-9A-Za-z_]*\))?\Z", re.IGNORECASE)

ARRAY_TAGS: dict[str, ParameterType] = {f"!{t.label}": t for t in ParameterType if t.is_array}
NOT_SET_TAG = "!not_set"
_ARRAY_OF = {
    ParameterType.BOOL: ParameterType.BOOL_ARRAY,
    ParameterType.INTEGER: ParameterType.INTEGER_ARRAY,
    ParameterType.DOUBLE: ParameterType.DOUBLE_ARRAY,
    ParameterType.STRING: ParameterType.STRING_ARRAY,
}


class UntypedEmptyList:
    """An untagged ``[]``: its type must come from elsewhere (see the module rules)."""

    __slots__ = ("line",)

    def __init__(self, line: int) -> None:
        self.line = line


def _strtoll(text: str) -> int | None:
    m = _INT.match(text)
    if m is None:
        return None
    sign, hexd, octd, decd = m.groups()
    if hexd is not None:
        v = int(hexd, 16)
    elif octd is not None:
        v = int(octd, 8)
    else:
        v = int(decd)
    if sign == "-":
        v = -v
    if not INT64_MIN <= v <= INT64_MAX:
        return None  # ERANGE: rcl moves on to strtod
    return v


def _strtod(text: str) -> float | None:
    if text in _YAML_INF_NAN:
        if "nan" in text.lower():
            return math.nan
        return -math.inf if text[0] == "-" else math.inf
    if _DEC.match(text):
        v = float(text)
    elif _HEX.match(text):
        try:
            v = float.fromhex(text)
        except OverflowError:
            return None  # ERANGE
    elif (m := _INF.match(text)) is not None:
        return -math.inf if m.group(1) == "-" else math.inf
    elif _NAN.match(text):
        return math.nan
    else:
        return None
    if math.isinf(v):
        return None  # a finite literal that overflows: ERANGE, so a string in rcl
    return v


def resolve_plain(text: str) -> ParameterValue:
    """The type and value rcl gives the plain (unquoted, untagged) scalar ``text``.

    ``text`` must not be empty (an empty plain scalar is "no value"; callers refuse it).
    """
    if text in _TRUE:
        return ParameterValue(ParameterType.BOOL, True)
    if text in _FALSE:
        return ParameterValue(ParameterType.BOOL, False)
    i = _strtoll(text)
    if i is not None:
        return ParameterValue(ParameterType.INTEGER, i)
    d = _strtod(text)
    if d is not None:
        return ParameterValue(ParameterType.DOUBLE, d)
    return ParameterValue(ParameterType.STRING, text)


def _who(name: str) -> str:
    return f"parameter {name!r}" if name else "value"


def _scalar(node: yaml.ScalarNode, source: Source, name: str, etype: ParameterType | None) -> ParameterValue:
    tag, text = node.tag, str(node.value)
    if tag == STR_TAG or node.style in ("'", '"'):
        value = ParameterValue.of(ParameterType.STRING, text)
    else:  # untagged, or a tag rcl ignores (``!!float 1`` is the integer 1, ``!custom x`` a string)
        if not text:
            raise source.error(f'{_who(name)}: no value (write "" for an empty string)', node)
        if etype is ParameterType.STRING:
            value = ParameterValue.of(ParameterType.STRING, text)
        else:
            value = resolve_plain(text)
    if etype is None or value.type is etype:
        return value
    if value.type is ParameterType.INTEGER and etype is ParameterType.DOUBLE:
        try:
            return value.coerce(etype)
        except ParamddsError as exc:
            raise source.error(f"{_who(name)}: {exc.message}", node) from exc
    raise source.error(
        f"{_who(name)}: expected {_article(etype)}, got {value.type.label} {value.show()}", node
    )


def _article(t: ParameterType) -> str:
    return ("an " if t.label[0] in "aeiou" else "a ") + t.label


def node_value(
    node: yaml.Node,
    source: Source,
    name: str = "",
    expected: ParameterType | None = None,
) -> ParameterValue | UntypedEmptyList:
    """The typed value of a value node, by the module rules.

    ``expected`` (when the format states the type) checks the value and types an
    empty list; ``name`` is used in messages. Returns :class:`UntypedEmptyList`
    for an untagged ``[]`` when no type is expected.
    """
    try:
        return _node_value(node, source, name, expected)
    except FileFormatError:
        raise
    except ParamddsError as exc:  # a value the value types refuse (a NUL, a lone surrogate...)
        raise source.error(f"{_who(name)}: {exc.message}", node) from exc


def _node_value(
    node: yaml.Node, source: Source, name: str, expected: ParameterType | None
) -> ParameterValue | UntypedEmptyList:
    if isinstance(node, yaml.ScalarNode):
        if node.tag == NOT_SET_TAG:
            if node.value != "" or expected not in (None, ParameterType.NOT_SET):
                raise source.error(f"{_who(name)}: !not_set takes no value", node)
            return NOT_SET
        if node.tag in ARRAY_TAGS:
            raise source.error(f"{_who(name)}: {node.tag} needs a list like [...]", node)
        if expected is not None and expected.is_array:
            raise source.error(f"{_who(name)}: expected {_article(expected)} (a list), got one value", node)
        return _scalar(node, source, name, expected)
    if isinstance(node, yaml.SequenceNode):
        return _sequence(node, source, name, expected)
    raise source.error(f"{_who(name)}: expected a value or a list, got a map", node)


def _sequence(
    node: yaml.SequenceNode, source: Source, name: str, expected: ParameterType | None
) -> ParameterValue | UntypedEmptyList:
    ptype = expected
    if node.tag in ARRAY_TAGS:
        ptype = ARRAY_TAGS[node.tag]
        if expected is not None and expected is not ptype:
            raise source.error(f"{_who(name)}: expected {_article(expected)}, got {node.tag}", node)
    if ptype is not None and not ptype.is_array:
        raise source.error(f"{_who(name)}: expected {_article(ptype)}, got a list", node)
    elems: list[yaml.ScalarNode] = []
    for item in node.value:
        if not isinstance(item, yaml.ScalarNode) or item.tag == NOT_SET_TAG or item.tag in ARRAY_TAGS:
            raise source.error(f"{_who(name)}: a list may hold only single values (no lists or maps)", item)
        elems.append(item)
    if ptype is ParameterType.BYTE_ARRAY:
        ints = [_scalar(e, source, name, ParameterType.INTEGER) for e in elems]
        for e, v in zip(elems, ints, strict=True):
            if not 0 <= int(v.value) <= 255:  # type: ignore[arg-type]
                raise source.error(f"{_who(name)}: a byte must be 0..255, got {v.show()}", e)
        return ParameterValue(ParameterType.BYTE_ARRAY, bytes(int(v.value) for v in ints))  # type: ignore[arg-type]
    if ptype is not None:
        etype = ptype.element
        assert etype is not None
        return ParameterValue.of(ptype, [_scalar(e, source, name, etype).value for e in elems])
    if not elems:
        return UntypedEmptyList(int(node.start_mark.line) + 1)
    values = [_scalar(e, source, name, None) for e in elems]
    first = values[0].type
    for e, v in zip(elems, values, strict=True):
        if v.type is not first:
            pair = {first, v.type}
            hint = (
                "; write every element as a double (1.0, not 1)"
                if pair == {ParameterType.INTEGER, ParameterType.DOUBLE}
                else ""
            )
            raise source.error(
                f"{_who(name)}: a list must hold one type, but {v.show()} is {_article(v.type)} "
                f"after {_article(first)}{hint}",
                e,
            )
    return ParameterValue.of(_ARRAY_OF[first], [v.value for v in values])


def typed_value(node: yaml.Node, source: Source, name: str, expected: ParameterType) -> ParameterValue:
    """:func:`node_value` when the type is known (so the result is always a value)."""
    value = node_value(node, source, name, expected)
    assert isinstance(value, ParameterValue)
    return value


def parse_cli_value(text: str, expected: ParameterType | None = None) -> ParameterValue:
    """A command-line value, typed exactly as the same text in a ROS 2 file.

    ``1`` integer, ``1.5`` double, ``true`` bool, ``[1, 2]`` integer array,
    ``abc`` string, ``"on"`` string (quoted). ``!not_set`` is the empty value.
    ``expected`` states the type (an integer widens to a double; ``abc def`` and
    ``5`` are strings when a string is expected). Raises
    :class:`~paramdds.errors.InvalidValueError` for text that is not one value.
    """
    source = Source("<command line>")
    quote_hint = f"; to pass it as a string, quote it: '\"{text}\"'"
    try:
        node = compose(text, source)
    except FileFormatError as exc:
        raise InvalidValueError(f"cannot read value {text!r}: {exc.detail}{quote_hint}") from exc
    if node is None:
        raise InvalidValueError('empty value; write "" for an empty string')
    if isinstance(node, yaml.MappingNode):
        raise InvalidValueError(f"{text!r} is a map, not a value{quote_hint}")
    try:
        value = node_value(node, source, "", expected)
    except FileFormatError as exc:
        raise InvalidValueError(f"cannot use value {text!r}: {exc.detail}") from exc
    if isinstance(value, UntypedEmptyList):
        raise InvalidValueError("an empty list has no type; write it as !integer_array [] (or another type)")
    return value
