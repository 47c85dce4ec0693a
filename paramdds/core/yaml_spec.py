"""Parameter specs in generate_parameter_library's YAML format, and declaring them.

::

    robot_params:                 # the root key: a namespace, not part of the names
      max_velocity:               # a leaf: a map with "type"
        type: double
        default_value: 1.5
        description: "Top speed in m/s"
        read_only: false
        additional_constraints: "a note for humans"
        validation:
          bounds<>: [0.0, 5.0]
      wheels:                     # any other map nests: wheels.count
        count:
          type: int
          validation:
            gt<>: [0]

**Types**: ``bool int double string bool_array int_array double_array
string_array``; ``string_fixed_N`` is a ``string`` of at most N characters and
``<t>_array_fixed_N`` (t = bool, int, double, string) an array of at most N
elements — both become the type plus a ``size_lt<>: [N + 1]`` validator; ``none``
is a dynamically typed parameter (descriptor type not_set, dynamic_typing).

**Leaf keys**: ``type`` (required), ``default_value``, ``description``,
``read_only``, ``additional_constraints``, ``validation``. Anything else (for
example generate_parameter_library's ``__map_*`` mapped parameters) is an
error, never ignored. A leaf without ``default_value`` is **required**: its
default is NOT_SET and :func:`declare_spec` needs a value for it from an
override. ``default_value`` must fit the type (integers widen to doubles; a
plain scalar for a string is taken as written; ``[]`` takes the array type).

**Validators** are spelled as that library does, ``name<>: [args]`` (the ``<>``
may be left out), with names from
:data:`~paramdds.core.descriptors.VALIDATOR_ARITY` and exactly that many
arguments (``null`` or ``[]`` for none): ``bounds<>: [0.0, 5.0]``, ``gt<>: [0]``,
``one_of<>: [["a", "b"]]``, ``unique<>: null``, ``size_gt<>: [2]``... Arguments
take the parameter's type (``bounds<>: [0, 5]`` on a double is ``0.0, 5.0``; the
list of ``one_of``/``subset_of`` is of the parameter's element type; sizes are
integers). A validator must suit its parameter (numeric bounds on numbers, sizes
on strings and arrays, ``unique``/``subset_of``/element bounds on arrays). A
custom validator (``my_ns::check``), an unknown name or a wrong number of
arguments is an error. ``bounds<>`` on an ``int`` or ``double`` also fills the
descriptor's integer/floating-point range (step 0), as the library does, so ROS
tools can show it.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from ..errors import InvalidValueError, ParamddsError
from .descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from .table import ParameterTable
from .values import NOT_SET, ParameterType, ParameterValue
from .yaml_base import Source, compose, expect_map, items, read_file
from .yaml_ros import parse_validator
from .yaml_scalar import node_value, typed_value

__all__ = ["SpecEntry", "declare_spec", "load_spec", "load_spec_str"]

T = ParameterType
_BASE_TYPES: dict[str, ParameterType] = {
    "bool": T.BOOL,
    "int": T.INTEGER,
    "double": T.DOUBLE,
    "string": T.STRING,
    "bool_array": T.BOOL_ARRAY,
    "int_array": T.INTEGER_ARRAY,
    "double_array": T.DOUBLE_ARRAY,
    "string_array": T.STRING_ARRAY,
    "none": T.NOT_SET,
}
_FIXED = re.compile(r"(string|bool_array|int_array|double_array|string_array)_fixed_([0-9]+)\Z")
_LEAF_KEYS = ("type", "default_value", "description", "read_only", "additional_constraints", "validation")
_NUMERIC = frozenset({T.INTEGER, T.DOUBLE})
_SCALAR_NUMERIC = ("bounds", "lower_bounds", "upper_bounds", "gt", "lt", "gt_eq", "lt_eq")
_ELEMENT = ("element_bounds", "lower_element_bounds", "upper_element_bounds")
_SIZED = ("size_gt", "size_lt", "fixed_size", "not_empty")


@dataclass(frozen=True, slots=True)
class SpecEntry:
    """One declared parameter: ``default`` is NOT_SET when the spec gives none (required)."""

    name: str
    default: ParameterValue
    descriptor: ParameterDescriptor

    @property
    def required(self) -> bool:
        return self.default.type is ParameterType.NOT_SET


def load_spec_str(text: str, *, source: str = "<string>") -> list[SpecEntry]:
    """Like :func:`load_spec` for text; ``source`` names it in errors."""
    src = Source(source)
    root = compose(text, src)
    if root is None:
        raise src.error("the spec is empty; expected one namespace key holding the parameters")
    roots = list(items(expect_map(root, src, "top level"), src, "top level"))
    if len(roots) != 1:
        raise src.error(f"a spec has exactly one root key (the namespace), found {len(roots)}", root)
    body = roots[0][2]
    out: list[SpecEntry] = []
    _walk(expect_map(body, src, "namespace"), "", src, out)
    return out


def load_spec(path: str | Path) -> list[SpecEntry]:
    """The parameters a spec file declares, in file order (rules in the module doc)."""
    return load_spec_str(read_file(path), source=str(path))


def _is_leaf(node: yaml.MappingNode) -> bool:
    return any(
        isinstance(k, yaml.ScalarNode) and k.value == "type" and isinstance(v, yaml.ScalarNode)
        for k, v in node.value
    )


def _walk(node: yaml.MappingNode, prefix: str, src: Source, out: list[SpecEntry]) -> None:
    for key, knode, vnode in items(node, src, f"group {prefix!r}" if prefix else "namespace"):
        name = f"{prefix}.{key}" if prefix else key
        if key.startswith("__"):
            raise src.error(f"parameter {name!r}: {key!r} (mapped parameters) is not supported", knode)
        if not isinstance(vnode, yaml.MappingNode):
            raise src.error(f"parameter {name!r}: expected a map with 'type' (or a group of them)", vnode)
        if _is_leaf(vnode):
            out.append(_leaf(name, vnode, src))
        else:
            _walk(vnode, name, src, out)


def _parse_type(name: str, node: yaml.ScalarNode, src: Source) -> tuple[ParameterType, int | None]:
    label = str(node.value)
    if label in _BASE_TYPES:
        return _BASE_TYPES[label], None
    m = _FIXED.match(label)
    if m is None:
        known = ", ".join([*_BASE_TYPES, "string_fixed_N", "<t>_array_fixed_N"])
        raise src.error(f"parameter {name!r}: unknown type {label!r} (known: {known})", node)
    return _BASE_TYPES[m.group(1)], int(m.group(2))


def _leaf(name: str, node: yaml.MappingNode, src: Source) -> SpecEntry:
    fields = {k: (kn, vn) for k, kn, vn in items(node, src, f"parameter {name!r}")}
    for key, (knode, _) in fields.items():
        if key not in _LEAF_KEYS:
            raise src.error(
                f"parameter {name!r}: unknown key {key!r} (known: {', '.join(_LEAF_KEYS)})", knode
            )
    type_node = fields["type"][1]
    assert isinstance(type_node, yaml.ScalarNode)
    ptype, fixed = _parse_type(name, type_node, src)
    dynamic = ptype is T.NOT_SET

    def text(key: str) -> str:
        if key not in fields:
            return ""
        return str(typed_value(fields[key][1], src, name, T.STRING).value)

    default: ParameterValue = NOT_SET
    if "default_value" in fields:
        raw = node_value(fields["default_value"][1], src, name, None if dynamic else ptype)
        if not isinstance(raw, ParameterValue):
            raise src.error(f"parameter {name!r}: an empty list has no type here", fields["default_value"][1])
        default = raw
    read_only = "read_only" in fields and bool(typed_value(fields["read_only"][1], src, name, T.BOOL).value)
    validators = _validators(name, ptype, fields["validation"][1], src) if "validation" in fields else []
    if fixed is not None:
        validators.append(Validator("size_lt", (ParameterValue(T.INTEGER, fixed + 1),)))
    int_range = fp_range = None
    for v in validators:
        if v.kind == "bounds" and ptype is T.INTEGER:
            int_range = IntegerRange(int(v.args[0].value), int(v.args[1].value))  # type: ignore[arg-type]
        elif v.kind == "bounds" and ptype is T.DOUBLE:
            fp_range = FloatingPointRange(float(v.args[0].value), float(v.args[1].value))  # type: ignore[arg-type]
    descriptor = ParameterDescriptor(
        name=name,
        type=ptype,
        description=text("description"),
        additional_constraints=text("additional_constraints"),
        read_only=read_only,
        dynamic_typing=dynamic,
        integer_range=int_range,
        floating_point_range=fp_range,
        validators=tuple(validators),
    )
    return SpecEntry(name, default, descriptor)


def _validators(name: str, ptype: ParameterType, node: yaml.Node, src: Source) -> list[Validator]:
    where = f"parameter {name!r} validation"
    out = []
    for key, knode, args in items(expect_map(node, src, where), src, where):
        kind = key[:-2] if key.endswith("<>") else key
        arg_type = _arg_type(name, kind, ptype, knode, src)
        out.append(parse_validator(kind, knode, args, src, name, arg_type))
    return out


def _arg_type(
    name: str, kind: str, ptype: ParameterType, knode: yaml.Node, src: Source
) -> ParameterType | None:
    """The type of ``kind``'s arguments on a ``ptype`` parameter; refuses a validator that cannot apply."""
    if ptype is T.NOT_SET:
        return None  # dynamically typed: arguments as written
    element = ptype.element
    ok = True
    arg: ParameterType | None = None
    if kind in _SCALAR_NUMERIC:
        ok, arg = ptype in _NUMERIC, ptype
    elif kind in _ELEMENT:
        ok, arg = element in _NUMERIC, element
    elif kind in _SIZED:
        ok, arg = ptype.is_array or ptype is T.STRING, T.INTEGER
    elif kind == "unique":
        ok = ptype.is_array
    elif kind == "subset_of":
        ok, arg = ptype.is_array, ptype
    elif kind == "one_of":
        ok = not ptype.is_array
        arg = {T.BOOL: T.BOOL_ARRAY, T.INTEGER: T.INTEGER_ARRAY, T.DOUBLE: T.DOUBLE_ARRAY}.get(
            ptype, T.STRING_ARRAY
        )
    if not ok:
        raise src.error(f"parameter {name!r}: validator {kind}<> does not apply to a {ptype.label}", knode)
    return arg


def declare_spec(table: ParameterTable, entries: Sequence[SpecEntry]) -> None:
    """Declare every entry on ``table``, all or nothing (overrides given to the table win).

    A required entry (no default in the spec) must get its value from an override.
    When some do not, nothing is declared and one
    :class:`~paramdds.errors.InvalidValueError` names each missing parameter; any other
    refusal by the table is raised as the table raised it.
    """
    try:
        table.declare_from([(e.name, e.default, e.descriptor) for e in entries])
    except ParamddsError as exc:
        missing = [e.name for e in entries if e.required and not _has_override(table, e.name)]
        if missing:
            raise InvalidValueError(
                "required parameters have no value (give them in a parameter file or as overrides): "
                + ", ".join(repr(n) for n in missing)
            ) from exc
        raise


def _has_override(table: ParameterTable, name: str) -> bool:
    """Whether ``table`` holds an override for ``name``, changing nothing.

    ``declare_from`` plans items in order and commits nothing when one fails. The first
    item is a dynamically typed bool with no value of its own, which the table refuses
    as "required, no value" (InvalidValueError) exactly when no override exists; the
    second has an invalid (empty) name, so the call always fails after the first item.
    """
    probe = ParameterDescriptor(name, ParameterType.BOOL, dynamic_typing=True)
    try:
        table.declare_from([(name, NOT_SET, probe), ("", NOT_SET, None)])
    except InvalidValueError:
        return False
    except ParamddsError:
        return True
    return True  # pragma: no cover - the empty name always fails
