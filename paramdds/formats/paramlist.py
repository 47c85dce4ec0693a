"""Parameter lists: a file's ``parameters:`` list of typed entries (``examples/params.yaml``)::

    parameters:
      - name: robot.max_velocity
        type: double          # bool, integer, double, string, byte_array,
        value: 1.5            # bool_array, integer_array, double_array, string_array

Rules: the top level is a map with the single key ``parameters``, a list of maps
with exactly the keys ``name``, ``type`` and ``value``. ``type`` is one of the nine
labels above. ``value`` is read by the shared resolver (:mod:`.scalar`) and
must fit ``type``: an integer is widened for a ``double`` (as
:meth:`ParameterValue.coerce` does), a plain scalar for a ``string`` is taken as
written (``value: 1.50`` is ``"1.50"``), an empty list takes the stated array
type, a ``byte_array`` is a list of integers 0..255. A repeated name is an error.
Nothing is skipped: every problem is a
:class:`~paramdds.errors.FileFormatError` naming the file, line and parameter,
and no partial list is returned. Order is kept.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from ..core.values import Parameter, ParameterType, ParameterValue
from .base import Source, compose, expect_map, items, line_of, read_file
from .scalar import node_value

__all__ = ["TYPES", "load_param_list", "load_param_list_str"]

TYPES: dict[str, ParameterType] = {t.label: t for t in ParameterType if t is not ParameterType.NOT_SET}
_KEYS = ("name", "type", "value")


def load_param_list_str(text: str, *, source: str = "<string>") -> list[Parameter]:
    """Like :func:`load_param_list` for text; ``source`` names it in errors."""
    src = Source(source)
    root = compose(text, src)
    if root is None:
        raise src.error("the file is empty; expected 'parameters:' with a list")
    top = dict((k, (kn, vn)) for k, kn, vn in items(expect_map(root, src, "top level"), src, "top level"))
    for key, (knode, _) in top.items():
        if key != "parameters":
            raise src.error(f"unknown top-level key {key!r} (expected only 'parameters')", knode)
    if "parameters" not in top:
        raise src.error("expected a top-level 'parameters:' list", root)
    plist = top["parameters"][1]
    if not isinstance(plist, yaml.SequenceNode):
        raise src.error("'parameters' must be a list of {name, type, value}", plist)
    out: list[Parameter] = []
    seen: dict[str, int] = {}
    for index, entry in enumerate(plist.value, start=1):
        param = _entry(entry, index, src)
        if param.name in seen:
            raise src.error(
                f"parameter {param.name!r} is given twice (first at line {seen[param.name]})", entry
            )
        seen[param.name] = line_of(entry)
        out.append(param)
    return out


def _entry(entry: yaml.Node, index: int, src: Source) -> Parameter:
    where = f"parameter #{index}"
    fields = {k: (kn, vn) for k, kn, vn in items(expect_map(entry, src, where), src, where)}
    name_node = fields.get("name", (None, None))[1]
    name = ""
    if name_node is not None:
        if not isinstance(name_node, yaml.ScalarNode) or not name_node.value:
            raise src.error(f"{where}: 'name' must be a non-empty text", name_node)
        name = str(name_node.value)
        where = f"parameter {name!r}"
    for key, (knode, _) in fields.items():
        if key not in _KEYS:
            raise src.error(f"{where}: unknown key {key!r} (expected name, type, value)", knode)
    for key in _KEYS:
        if key not in fields:
            raise src.error(f"{where}: missing key {key!r}", entry)
    type_node = fields["type"][1]
    label = type_node.value if isinstance(type_node, yaml.ScalarNode) else None
    if label not in TYPES:
        raise src.error(f"{where}: unknown type {label!r} (known: {', '.join(TYPES)})", type_node)
    value = node_value(fields["value"][1], src, name, TYPES[label])
    assert isinstance(value, ParameterValue)
    return Parameter(name, value)


def load_param_list(path: str | Path) -> list[Parameter]:
    """The parameters of a parameter list file, in file order (rules in the module doc)."""
    return load_param_list_str(read_file(path), source=str(path))
