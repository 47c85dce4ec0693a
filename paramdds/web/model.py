"""What the console shows and accepts, as JSON: pure functions, no DDS, no HTTP.

Shapes (documented in docs/web.md):

* a node summary: ``{"node", "online", "host", "pid", "revision", "parameters",
  "request_filter", "incarnation", "origin", "status"}`` (the incarnation in 16 hex digits);
* a parameter row: ``{"name", "value", "type", "descriptor", "choices", "last_change"}`` with the value
  and descriptor in the CLI's JSON shapes (:mod:`paramdds.core.jsonform`: byte arrays as
  lists of ints, non-finite doubles as ``"nan"``/``"inf"``/``"-inf"``) and the choices its
  editor offers (:func:`choices`: a ``one_of`` or a schema ``enum``), or null, and who last
  changed it (:meth:`LastChange.to_json`: ``{"who", "verified", "via", "time", "revision"}``),
  or null when the node did not say;
* a set result: ``{"name", "successful", "reason", "code"}``;
* a history record (:func:`history_row`): the CLI's ``history -o json`` record, with ``seq``,
  ``code`` and the type of each of ``old`` and ``new`` (how the page writes them).

Values sent by a browser are typed by the parameter's descriptor
(:func:`typed_value`, with the rule every front end shares, :mod:`paramdds.core.fit`):
``1`` for a double parameter is ``1.0``, a byte array may be a hex string, and the
value is checked against the descriptor with the same core
validation the node runs, so a value the node would refuse never leaves this
process and the reason shown is the node's own wording.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict
from functools import lru_cache

from ..core.descriptors import ParameterDescriptor
from ..core.fit import EMPTY_LIST, EmptyList, fit_value
from ..core.history import HistoryRecord
from ..core.jsonform import json_descriptor, json_value
from ..core.limits import check_value
from ..core.names import validate_name
from ..core.results import LastChange, SetResult
from ..core.revision import incarnation_text
from ..core.validation import validate
from ..core.values import Parameter, ParameterType, ParameterValue
from ..dds.client import NodeInfo
from ..errors import ErrorCode, InvalidValueError, ParamddsError, TypeMismatchError
from .status import code_of

Row = dict[str, object]
_HEX = re.compile(r"^(?:0x)?((?:[0-9a-fA-F]{2})*)$")
_NON_FINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}
_ENUM = re.compile(r"(?:^|; |, )one of ")  # a schema enum as formats.schema.describe writes it
_JSON = json.JSONDecoder()


def _is_int(x: object) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _is_double(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


_ENUM_TYPES = {"string": lambda x: isinstance(x, str), "integer": _is_int, "double": _is_double}


def summary_json(info: NodeInfo) -> Row:
    """A node's line in the node list: the client's :class:`NodeInfo` as JSON (the
    incarnation in 16 hex digits: a JSON number loses digits above 2**53 in a browser)."""
    row = asdict(info)
    row["incarnation"] = incarnation_text(info.incarnation)
    return row


def parameter_row(
    name: str,
    value: ParameterValue,
    descriptor: ParameterDescriptor | None,
    last_change: LastChange | None = None,
) -> Row:
    described = json_descriptor(descriptor or ParameterDescriptor(name, value.type))
    return {
        "name": name,
        "value": json_value(value),
        "type": value.type.label,
        "descriptor": described,
        "choices": choices(described, value.type),
        "last_change": last_change_json(last_change) if last_change is not None else None,
    }


@lru_cache(maxsize=4096)
def last_change_json(last: LastChange) -> Row:
    """:meth:`LastChange.to_json`, made once per change (its time's text costs ~20 µs, and a
    node's rows mostly share a few changes: the one it started with, a file loaded)."""
    return last.to_json()


def history_row(record: HistoryRecord) -> Row:
    """One record of a parameter's timeline: as ``paramdds history -o json`` prints it, plus
    its ``seq``, its refusal ``code`` and the types its ``old`` and ``new`` values are of."""
    row = record.to_json()
    row["seq"] = record.seq
    row["code"] = record.code or None
    row["old_type"] = record.old.type.label if record.old is not None else None
    row["new_type"] = record.new.type.label if record.new is not None else None
    return row


def choices(descriptor: Mapping[str, object], value_type: ParameterType) -> list[object] | None:
    """The values a parameter's editor offers as a choice list, or None for a free editor.

    ``descriptor`` is in its JSON shape. The choices are a ``one_of`` validator's (a
    generate_parameter_library spec's ``one_of<>``, a parameter file's ``validators``), on
    any parameter that is not an array; else, on a string, integer or double parameter, a
    JSON Schema ``enum``, which reaches the descriptor only as the text
    ``one of [...]`` (JSON) among its additional constraints
    (:mod:`paramdds.formats.schema.describe`: nothing new travels on the wire), when every
    value it lists is of the parameter's type.
    """
    label = str(descriptor.get("type"))
    if (value_type.label if label == "not_set" else label).endswith("_array"):
        return None
    validators = descriptor.get("validators")
    for v in validators if isinstance(validators, list) else []:
        if v["kind"] == "one_of" and v["args"] and isinstance(v["args"][0], list):
            return list(v["args"][0])
    fits = _ENUM_TYPES.get(label)
    text = descriptor.get("additional_constraints")
    if fits is None or not isinstance(text, str):
        return None
    for m in reversed(list(_ENUM.finditer(text))):  # the parameter's own keywords come last
        try:
            found, _ = _JSON.raw_decode(text, m.end())
        except ValueError:
            continue
        if isinstance(found, list) and found and all(fits(x) for x in found):
            return found
    return None


def result_row(r: SetResult) -> Row:
    return {
        "name": r.name,
        "successful": r.successful,
        "reason": r.reason,
        "code": r.code.value if r.code is not None else None,
    }


def matches(query: str, node: str, names: Iterable[str]) -> bool:
    """Whether a node is shown for a search: its id or one of its parameter names contains ``query``."""
    q = query.strip().lower()
    return not q or q in node.lower() or any(q in n.lower() for n in names)


# -- values from a browser ----------------------------------------------------------------


def _double(name: str, raw: object) -> float:
    if isinstance(raw, str) and raw.strip().lower() in _NON_FINITE:
        return _NON_FINITE[raw.strip().lower()]
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise TypeMismatchError(f"Parameter {name!r} expects a double, got {_kind(raw)}")
    try:
        return float(raw)
    except OverflowError:
        raise InvalidValueError(f"Parameter {name!r}: {raw} does not fit in a double") from None


def _bytes(name: str, raw: object) -> bytes:
    if isinstance(raw, str):
        compact = "".join(raw.split())
        m = _HEX.match(compact)
        if m is None:
            raise TypeMismatchError(
                f"Parameter {name!r} expects bytes as hex (an even number of 0-9a-f digits), got {raw[:40]!r}"
            )
        return bytes.fromhex(m.group(1))
    value = ParameterValue.of(ParameterType.BYTE_ARRAY, raw)
    assert isinstance(value.value, bytes)
    return value.value


def _kind(raw: object) -> str:
    if raw is None:
        return "null"
    if isinstance(raw, bool):
        return "a bool"
    if isinstance(raw, (int, float)):
        return "a number"
    if isinstance(raw, str):
        return "a string"
    if isinstance(raw, list):
        return "a list"
    return "an object"


def _as_type(name: str, ptype: ParameterType, raw: object) -> ParameterValue:
    if ptype is ParameterType.DOUBLE:
        return ParameterValue.of(ptype, _double(name, raw))
    if ptype is ParameterType.DOUBLE_ARRAY:
        if not isinstance(raw, list):
            raise TypeMismatchError(f"Parameter {name!r} expects a double_array, got {_kind(raw)}")
        return ParameterValue.of(ptype, [_double(name, x) for x in raw])
    if ptype is ParameterType.BYTE_ARRAY:
        return ParameterValue.of(ptype, _bytes(name, raw))
    try:
        return ParameterValue.of(ptype, raw)
    except TypeMismatchError as exc:
        raise TypeMismatchError(f"Parameter {name!r}: {exc.message}") from None


def typed_value(name: str, raw: object, descriptor: ParameterDescriptor | None) -> ParameterValue:
    """The value a browser sent for ``name``, typed and checked as the node would check it.

    Raises the same :class:`~paramdds.errors.ParamddsError` (and reason) the node would:
    TYPE_MISMATCH, OUT_OF_RANGE, INVALID_VALUE, READ_ONLY is left to the node.
    """
    validate_name(name)
    if raw is None:
        raise InvalidValueError(f"Parameter {name!r}: null is not a value (delete the parameter instead)")
    fixed = descriptor is not None and not descriptor.dynamic_typing
    value: ParameterValue | EmptyList
    if isinstance(raw, list) and not raw:
        value = EMPTY_LIST  # its type is the descriptor's (core.fit)
    elif fixed and descriptor is not None and descriptor.type is not ParameterType.NOT_SET:
        value = _as_type(name, descriptor.type, raw)
    elif isinstance(raw, dict):
        raise TypeMismatchError(f"Parameter {name!r}: cannot make a parameter value of an object")
    else:
        value = ParameterValue.from_python(raw)
    return checked(name, value, descriptor)


def checked(
    name: str, value: ParameterValue | EmptyList, descriptor: ParameterDescriptor | None
) -> ParameterValue:
    """``value`` typed against the descriptor as every front end types it
    (:func:`paramdds.core.fit.fit_value`: an empty list, bytes, an integer for a double), then
    checked against our size limits and the descriptor (the node's own rules, in the core)."""
    typed = fit_value(name, value, descriptor)
    check_value(name, typed)
    if descriptor is not None:
        validate(name, typed, descriptor)
    return typed


def typed_parameters(
    raw: Mapping[str, object], described: Mapping[str, tuple[ParameterValue, ParameterDescriptor]]
) -> tuple[list[Parameter], list[Row]]:
    """Every value of a request typed by the node's descriptors: (the parameters that pass,
    a refused result row for each of the rest, with the reason and code the node would give)."""
    params: list[Parameter] = []
    refused: list[Row] = []
    for name, v in raw.items():
        entry = described.get(name)
        try:
            params.append(Parameter(name, typed_value(name, v, entry[1] if entry else None)))
        except ParamddsError as exc:
            refused.append(refused_row(name, exc.message, code_of(exc)))
    return params, refused


def refused_row(name: str, reason: str, code: str) -> Row:
    return {"name": name, "successful": False, "reason": reason, "code": code}


def atomic_refusal(names: Iterable[str], rows: Sequence[Row]) -> list[Row]:
    """The rows of an atomic write refused before it was sent, one per name of ``names``: the
    rows given (the first refusal among them is the cause), every other name not applied, in
    the node's words for an atomic failure."""
    given = {str(r["name"]): r for r in rows}
    cause = next(r["name"] for r in rows if not r["successful"])
    other = f"not applied: the atomic set failed on {cause!r}"
    return [given.get(n) or refused_row(n, other, ErrorCode.INVALID_VALUE.value) for n in names]
