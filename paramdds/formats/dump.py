"""Writing a node's parameters as a ROS 2 parameter file that reads back exactly.

``dump_ros_params(node_id, snapshot)`` writes (a node in a namespace, ``ns/robot1``,
under its absolute name ``/ns/robot1``)::

    robot1:
      ros__parameters:
        robot:
          enabled: true
          max_velocity: 1.0
          name: "1.5"

The output is a pure function of the snapshot (sorted by name), so
dump → load → dump is byte-identical. Rules:

* Names are split on ``.`` into nested maps. When a name is both a value and a
  prefix (``a`` and ``a.b``), the longer names are written as dotted keys
  (``a.b: 2``) beside ``a: 1``; a name with an empty part (``a..b``) is written
  as one key. Both forms load to the same names, in ROS too.
* Bools ``true``/``false``; integers in decimal; doubles always with a ``.``, and
  an exponent with its sign (``1.0``, ``1.0e-10``, ``1.0e+100``: Python's shortest
  repr, which reads back to the same bits, with ``.0`` added to a mantissa without a
  ``.`` and ``+`` to an exponent without a sign), so that rcl, PyYAML (YAML 1.1, which
  reads ``1e-10`` as a string; launch's RewrittenYaml uses it) and ours all read a
  double; and ``.nan``, ``.inf``, ``-.inf``. A subnormal double (below
  2.2250738585072014e-308) is written so too, but rcl reads no form of it as a double
  (strtod reports an underflow): it reads a string.
* A string is written plain only when it is a simple word that the resolver reads
  back as that same string and no other YAML tool would take for a bool or null;
  otherwise it is double-quoted with escapes (``"on"``, ``"1.5"``, ``"null"``,
  ``""``, ``"a: b"``). Unicode is written as is; control characters, YAML line
  breaks and characters YAML cannot carry are escaped.
* Arrays are flow lists (``[1.0, 2.5]``). An **empty array** carries its type as a
  tag (``!double_array []``) and a **byte array** is always tagged
  (``!byte_array [0, 255]``): plain ROS has no byte arrays and no typed empty
  list. A parameter with no value is ``!not_set``. These three forms are ours;
  everything else is plain ROS 2.
* ``with_descriptors=True`` adds a ``paramdds__descriptors`` map beside
  ``ros__parameters`` (format in :mod:`.ros`): paramdds reads it, ROS 2 cannot (rcl
  refuses the whole file: "Cannot have a value before ros__parameters"), so
  ``paramdds dump`` writes it only when asked (``--descriptors``).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterable, Sequence

from ..core.descriptors import ParameterDescriptor, Validator
from ..core.values import ParameterType, ParameterValue
from ..errors import InvalidNameError
from .ros import DESCRIPTORS_KEY, PARAMS_KEY
from .scalar import resolve_plain

__all__ = ["dump_ros_params", "format_value"]

SnapshotItem = tuple[str, ParameterValue, "ParameterDescriptor | None"]

_SIMPLE = re.compile(r"[A-Za-z_/][A-Za-z0-9_./\-]*\Z")
# Words other YAML tools (PyYAML, YAML 1.1) read as null or bool: always quoted.
_OTHER_TOOLS = frozenset(
    {"null", "Null", "NULL", "true", "True", "TRUE", "false", "False", "FALSE", "yes", "Yes", "YES"}
    | {"no", "No", "NO", "on", "On", "ON", "off", "Off", "OFF", "y", "Y", "n", "N"}
)
_ESCAPES = {
    "\\": "\\\\",
    '"': '\\"',
    "\0": "\\0",
    "\a": "\\a",
    "\b": "\\b",
    "\t": "\\t",
    "\n": "\\n",
    "\v": "\\v",
    "\f": "\\f",
    "\r": "\\r",
    "\x1b": "\\e",
    "\x85": "\\N",
    "\u2028": "\\L",
    "\u2029": "\\P",
    "\ufeff": "\\uFEFF",
}
_NEEDS_ESCAPE = re.compile('[\\\\"\x00-\x1f\x7f-\x9f\u2028\u2029\ufeff\ud800-\udfff\ufffe\uffff]')


def _escape(ch: str) -> str:
    if ch in _ESCAPES:
        return _ESCAPES[ch]
    code = ord(ch)
    return f"\\x{code:02X}" if code <= 0xFF else f"\\u{code:04X}"


def _quote(text: str) -> str:
    return '"' + _NEEDS_ESCAPE.sub(lambda m: _escape(m.group()), text) + '"'


def _plain_ok(text: str) -> bool:
    return (
        _SIMPLE.match(text) is not None
        and text not in _OTHER_TOOLS
        and resolve_plain(text).type is ParameterType.STRING
    )


def _string(text: str) -> str:
    return text if _plain_ok(text) else _quote(text)


def _double(v: float) -> str:
    if math.isnan(v):
        return ".nan"
    if math.isinf(v):
        return ".inf" if v > 0 else "-.inf"
    mantissa, e, exponent = repr(v).partition("e")
    if not e:
        return mantissa  # repr always has a "." without an exponent ("1.0", "0.001")
    if "." not in mantissa:
        mantissa += ".0"
    if exponent[0] not in "+-":
        exponent = "+" + exponent
    return f"{mantissa}e{exponent}"


def _scalar(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _double(v)
    assert isinstance(v, str)
    return _string(v)


def format_value(value: ParameterValue) -> str:
    """One value in flow form, as the dump writes it (reads back to the same value)."""
    t, v = value.type, value.value
    if t is ParameterType.NOT_SET:
        return "!not_set"
    if t is ParameterType.BYTE_ARRAY:
        assert isinstance(v, bytes)
        return "!byte_array [" + ", ".join(str(b) for b in v) + "]"
    if t.is_array:
        assert isinstance(v, tuple)
        if not v:
            return f"!{t.label} []"
        return "[" + ", ".join(_scalar(x) for x in v) + "]"
    return _scalar(v)


def _key(text: str) -> str:
    return text if _plain_ok(text) else _quote(text)


def _emit_tree(entries: Sequence[tuple[list[str], ParameterValue]], indent: int, out: list[str]) -> None:
    """Write ``entries`` (name parts, value), grouped by first part in order of appearance."""
    pad = " " * indent
    groups: dict[str, list[tuple[list[str], ParameterValue]]] = {}
    for parts, value in entries:
        groups.setdefault(parts[0], []).append((parts, value))
    for head, group in groups.items():
        leaf = next((value for parts, value in group if len(parts) == 1), None)
        if leaf is not None:
            out.append(f"{pad}{_key(head)}: {format_value(leaf)}")
            for parts, value in group:
                if len(parts) > 1:
                    out.append(f"{pad}{_key('.'.join(parts))}: {format_value(value)}")
        else:
            out.append(f"{pad}{_key(head)}:")
            _emit_tree([(parts[1:], value) for parts, value in group], indent + 2, out)


def _parts(name: str) -> list[str]:
    parts = name.split(".")
    return [name] if "" in parts else parts


def _descriptor_lines(d: ParameterDescriptor, pad: str) -> list[str]:
    lines = [f"{pad}type: {d.type.label}"]
    if d.description:
        lines.append(f"{pad}description: {_string(d.description)}")
    if d.additional_constraints:
        lines.append(f"{pad}additional_constraints: {_string(d.additional_constraints)}")
    if d.read_only:
        lines.append(f"{pad}read_only: true")
    if d.dynamic_typing:
        lines.append(f"{pad}dynamic_typing: true")
    if d.integer_range is not None:
        r = d.integer_range
        lines.append(f"{pad}integer_range: [{r.from_value}, {r.to_value}, {r.step}]")
    if d.floating_point_range is not None:
        f = d.floating_point_range
        rng = ", ".join(_double(float(x)) for x in (f.from_value, f.to_value, f.step))
        lines.append(f"{pad}floating_point_range: [{rng}]")
    if d.validators:
        lines.append(f"{pad}validators:")
        lines.extend(f"{pad}  - {_validator(v)}" for v in d.validators)
    return lines


def _validator(v: Validator) -> str:
    return f"{v.kind}: [" + ", ".join(format_value(a) for a in v.args) + "]"


def dump_ros_params(
    node_id: str,
    snapshot: Iterable[tuple[str, ParameterValue, ParameterDescriptor | None]],
    *,
    with_descriptors: bool = False,
) -> str:
    """A ROS 2 parameter file holding ``snapshot`` for ``node_id`` (rules in the module doc).

    ``snapshot`` is what :meth:`ParameterTable.snapshot` returns (any order; a ``None``
    descriptor is allowed and writes no descriptor entry).
    """
    items = sorted(snapshot, key=lambda item: item[0])
    for a, b in itertools.pairwise(items):
        if a[0] == b[0]:
            raise InvalidNameError(f"parameter {a[0]!r} appears twice in the snapshot")
    if items and not items[0][0]:
        raise InvalidNameError("a parameter name cannot be empty")
    # a node in a namespace by its absolute name, as `ros2 param dump` writes it (rclpy's
    # parameter_dict_from_yaml_file finds "/ns/name" or "name", not "ns/name")
    out = [f"{_key('/' + node_id if '/' in node_id else node_id)}:", f"  {PARAMS_KEY}:"]
    if items:
        _emit_tree([(_parts(name), value) for name, value, _ in items], 4, out)
    else:
        out[-1] += " {}"
    if with_descriptors:
        described = [(name, d) for name, _, d in items if d is not None]
        if described:
            out.append(f"  {DESCRIPTORS_KEY}:")
            for name, d in described:
                out.append(f"    {_key(name)}:")
                out.extend(_descriptor_lines(d, " " * 6))
    return "\n".join(out) + "\n"
