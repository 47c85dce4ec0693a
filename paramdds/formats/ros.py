"""ROS 2 parameter files: node sections, ``ros__parameters``, wildcards, precedence.

The layout is rcl_yaml_param_parser's::

    /**:                      # every node
      ros__parameters:
        use_sim_time: false
    /ns/robot1:               # or "robot1", or nested: ns: {robot1: {ros__parameters: ...}}
      ros__parameters:
        robot:
          max_velocity: 1.5   # nested maps flatten to dotted names: robot.max_velocity
        "a.b": 1              # a key may itself hold dots

**Node keys.** The keys above ``ros__parameters`` are joined with ``/`` into a
node name (``ns: {robot1: ...}`` is ``ns/robot1``). Each ``/``-separated token is
``*``, ``**`` or a ROS name token (``[A-Za-z_][A-Za-z0-9_]*``); anything else is an
error, as rcl validates node names and namespaces.

**Matching** follows rclcpp's ``parameter_map_from``: a leading ``/`` is added to
the key, then ``/*`` becomes ``(/\\w+)`` — so ``/*`` matches exactly one token and
``/**`` any number of tokens (zero or more) — and the whole node name must match.
Node ids are canonical without the leading slash: ``robot1`` matches the keys
``robot1``, ``/robot1``, ``/*``, ``/**``; ``ns/robot1`` matches ``/ns/robot1``,
``/ns/*``, ``/**/robot1``, ``/**`` but not ``/*`` or ``robot1``.

**Precedence** is rcl's: sections are kept in order of the first appearance of
their node key; all sections matching the node are applied in that order, so a
later matching section overrides an earlier one (``robot1`` written after ``/**``
wins over it; written before, ``/**`` wins). The same node key written twice (for
example ``/ns/robot1`` and ``/ns: {robot1: …}``, or ``/**:`` twice at the top
level) is one section, merged as rcl merges it (see ``_merge_repeated``). The root
namespace key ``/`` followed by a node (``/: {my_node: …}``) is node ``/my_node``.

**Values** are typed by :mod:`.scalar` (rcl's rules). Differences from rcl,
each to fail loudly rather than guess: a name given twice in one
``ros__parameters`` map is an error (rcl keeps the last); an untagged ``[]`` is
an error unless a descriptor types it (rcl loads an empty list as no value and
rclcpp then throws). As in rcl, anchors/aliases and merge keys ``<<`` are refused.

**Descriptors** (our extension, written by ``dump_ros_params(...,
with_descriptors=True)``; ROS tools cannot read this form) sit beside
``ros__parameters``::

    robot1:
      ros__parameters: {...}
      paramdds__descriptors:
        robot.max_velocity:          # the full parameter name
          type: double               # always present
          description: "Top speed"   # the rest only when not the default
          additional_constraints: "..."
          read_only: true
          dynamic_typing: true
          integer_range: [0, 10, 1]          # from, to, step
          floating_point_range: [0.0, 5.0, 0.0]
          validators:                         # in order; VALIDATOR_ARITY names or custom ns::fn
            - bounds: [0.0, 5.0]
            - one_of: [["a", "b"]]
            - unique: []

A descriptor needs a value for the same name in its section's ``ros__parameters``.
The value is checked against the descriptor's type (an integer widens to a
double; ``[]`` takes the descriptor's array type).

Whole files or nothing: the entire file (every section, matching or not) is
checked before anything is returned. Every error is a
:class:`~paramdds.errors.FileFormatError` naming the file, line and parameter.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from ..core.descriptors import (
    VALIDATOR_ARITY,
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    Validator,
)
from ..core.values import ParameterType, ParameterValue
from ..errors import FileFormatError, ParamddsError
from .base import PLAIN_TAG, SEQ_TAG, Source, compose, expect_map, items, key_text, line_of, read_file
from .scalar import UntypedEmptyList, node_value, typed_value

__all__ = [
    "DESCRIPTORS_KEY",
    "PARAMS_KEY",
    "load_ros_file_full",
    "load_ros_params",
    "load_ros_params_str",
    "load_ros_text_full",
    "node_key_matches",
    "node_keys",
]

PARAMS_KEY = "ros__parameters"
DESCRIPTORS_KEY = "paramdds__descriptors"

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_RawValue = ParameterValue | UntypedEmptyList


@dataclass
class _Section:
    values: dict[str, tuple[_RawValue, int]] = field(default_factory=dict)
    descriptors: dict[str, tuple[ParameterDescriptor, int]] = field(default_factory=dict)


def node_key_matches(key: str, node_id: str) -> bool:
    """Whether the node key ``key`` (``/**``, ``/ns/*``, ``robot1``…) applies to ``node_id``."""
    pattern = key if key.startswith("/") else "/" + key
    regex = re.escape(pattern).replace(r"/\*", r"(/\w+)").replace(r"\*", "*")
    fqn = node_id if node_id.startswith("/") else "/" + node_id
    return re.fullmatch(regex, fqn, re.ASCII) is not None


def _check_node_name(name: str, source: Source, node: yaml.Node) -> None:
    if name in ("/**", "/*"):
        return
    body = name[1:] if name.startswith("/") else name
    for token in body.split("/"):
        if token in ("*", "**"):
            continue
        if not token:
            raise source.error(f"node name {name!r} has an empty part (repeated '/')", node)
        if not _TOKEN.match(token):
            raise source.error(
                f"node name {name!r}: {token!r} is not a valid name (letters, digits, '_'; "
                "not starting with a digit) nor a wildcard (*, **)",
                node,
            )


def _parse(text: str, source: Source) -> dict[str, _Section]:
    root = compose(text, source)
    sections: dict[str, _Section] = {}
    if root is None:
        return sections
    _walk_nodes(expect_map(root, source, "top level"), "", source, sections)
    return sections


def _walk_nodes(node: yaml.MappingNode, prefix: str, source: Source, out: dict[str, _Section]) -> None:
    where = f"node {prefix!r}" if prefix else "top level"
    local: dict[str, tuple[_RawValue, int]] | None = None
    descs: tuple[yaml.Node, yaml.Node] | None = None
    for key, knode, vnode in _node_items(node, source, where):
        if key in (PARAMS_KEY, DESCRIPTORS_KEY) and not prefix:
            raise source.error(f"{key} needs a node name above it (for example /**:)", knode)
        if key == DESCRIPTORS_KEY:
            descs = (knode, vnode)
        elif key == PARAMS_KEY:
            _check_node_name(prefix, source, knode)
            section = out.setdefault(prefix, _Section())
            local = {}
            nested: set[str] = set()
            if _is_null(vnode):  # rcl: "Cannot have a value before ros__parameters"
                raise source.error(
                    f"node {prefix!r}: {PARAMS_KEY} is empty; write '{PARAMS_KEY}: {{}}' for a node "
                    "without parameters",
                    knode,
                )
            params = expect_map(vnode, source, f"node {prefix!r} {PARAMS_KEY}")
            _walk_params(params, "", source, local, nested)
            _merge_repeated(section.values, local, nested)
        else:
            name = f"{prefix}{key}" if prefix.endswith("/") else f"{prefix}/{key}" if prefix else key
            if not isinstance(vnode, yaml.MappingNode):
                raise source.error(f"node {name!r}: expected a map with {PARAMS_KEY}, got a value", vnode)
            _walk_nodes(vnode, name, source, out)
    if descs is None:
        return
    if local is None:
        raise source.error(f"node {prefix!r}: {DESCRIPTORS_KEY} without {PARAMS_KEY}", descs[0])
    where = f"node {prefix!r} {DESCRIPTORS_KEY}"
    for pname, pknode, dnode in items(expect_map(descs[1], source, where), source, where):
        if pname not in local:
            raise source.error(
                f"parameter {pname!r}: a descriptor without a value in this section's {PARAMS_KEY}", pknode
            )
        out[prefix].descriptors[pname] = (_descriptor(pname, dnode, source), line_of(pknode))


# The order in which rclcpp (parameter_map.cpp, parameter_value_from) reads the typed slots of
# rcl's rcl_variant_t: a value of another type never replaces one earlier in this order.
_RCL_SLOTS = (
    ParameterType.BOOL,
    ParameterType.INTEGER,
    ParameterType.DOUBLE,
    ParameterType.STRING,
    ParameterType.BYTE_ARRAY,
    ParameterType.BOOL_ARRAY,
    ParameterType.INTEGER_ARRAY,
    ParameterType.DOUBLE_ARRAY,
    ParameterType.STRING_ARRAY,
)


def _merge_repeated(
    values: dict[str, tuple[_RawValue, int]], later: dict[str, tuple[_RawValue, int]], nested: set[str]
) -> None:
    """A node key written again, as rcl merges it (measured against rcl 10.1).

    A parameter written again inside a map (``c: {d: 2}``) is a new entry in rcl, and the
    later entry wins. One written again as a key of ``ros__parameters`` itself (``a: 2``,
    ``c.d: 2``) updates rcl's existing entry, which keeps one slot per type (parse.c,
    parse_value): only the slot of the new value's type is overwritten, so the later value
    wins when the types agree, and otherwise the value whose type rclcpp reads first stays
    (an empty list sets no slot)."""
    for name, (raw, line) in later.items():
        old = values.get(name)
        if name in nested or old is None or isinstance(old[0], UntypedEmptyList):
            values[name] = (raw, line)
        elif isinstance(raw, UntypedEmptyList):
            continue
        elif _RCL_SLOTS.index(raw.type) <= _RCL_SLOTS.index(old[0].type):
            values[name] = (raw, line)


def _node_items(
    node: yaml.MappingNode, source: Source, where: str
) -> Iterator[tuple[str, yaml.Node, yaml.Node]]:
    """The keys of a map above ``ros__parameters``: a node key written twice is merged, as rcl does.

    Only ``ros__parameters`` and ``paramdds__descriptors`` may not repeat under one node key.
    """
    seen: dict[str, int] = {}
    for knode, vnode in node.value:
        key = key_text(knode, source, where)
        if key in seen and key in (PARAMS_KEY, DESCRIPTORS_KEY):
            raise source.error(f"{where}: key {key!r} is repeated (first at line {seen[key]})", knode)
        seen.setdefault(key, line_of(knode))
        yield key, knode, vnode


def _is_null(node: yaml.Node) -> bool:
    return isinstance(node, yaml.ScalarNode) and node.tag == PLAIN_TAG and node.value == ""


def _walk_params(
    node: yaml.MappingNode,
    prefix: str,
    source: Source,
    out: dict[str, tuple[_RawValue, int]],
    nested: set[str],
) -> None:
    """Flatten ``node`` into ``out``; ``nested`` gets the names written inside a map."""
    where = f"parameters under {prefix!r}" if prefix else PARAMS_KEY
    for key, knode, vnode in items(node, source, where):
        name = f"{prefix}.{key}" if prefix else key
        if isinstance(vnode, yaml.MappingNode):
            if not vnode.value:  # rcl makes it a parameter without a value, or nests the next key in it
                raise source.error(f"parameter {name!r}: an empty map {{}} is not a value", vnode)
            _walk_params(vnode, name, source, out, nested)
            continue
        if name in out:
            raise source.error(f"parameter {name!r} is given twice (first at line {out[name][1]})", knode)
        out[name] = (node_value(vnode, source, name), line_of(knode))
        if prefix:
            nested.add(name)


_TYPES = {t.label: t for t in ParameterType}
_DESC_FIELDS = (
    "type",
    "description",
    "additional_constraints",
    "read_only",
    "dynamic_typing",
    "integer_range",
    "floating_point_range",
    "validators",
)


def _descriptor(name: str, node: yaml.Node, source: Source) -> ParameterDescriptor:
    fields = dict((k, v) for k, _, v in items(expect_map(node, source, f"parameter {name!r}"), source, name))
    for key in fields:
        if key not in _DESC_FIELDS:
            raise source.error(
                f"parameter {name!r}: unknown descriptor field {key!r} (known: {', '.join(_DESC_FIELDS)})",
                fields[key],
            )
    if "type" not in fields:
        raise source.error(f"parameter {name!r}: the descriptor needs a type", node)

    def text(key: str) -> str:
        if key not in fields:
            return ""
        return str(typed_value(fields[key], source, name, ParameterType.STRING).value)

    def flag(key: str) -> bool:
        return key in fields and bool(typed_value(fields[key], source, name, ParameterType.BOOL).value)

    label = text("type")
    ptype = _TYPES.get(label)
    if ptype is None:
        known = ", ".join(t.label for t in ParameterType)
        raise source.error(f"parameter {name!r}: unknown type {label!r} (known: {known})", fields["type"])
    int_range = fp_range = None
    if "integer_range" in fields:
        lo, hi, step = _range(fields["integer_range"], source, name, ParameterType.INTEGER_ARRAY)
        int_range = IntegerRange(int(lo), int(hi), int(step))
    if "floating_point_range" in fields:
        flo, fhi, fstep = _range(fields["floating_point_range"], source, name, ParameterType.DOUBLE_ARRAY)
        fp_range = FloatingPointRange(flo, fhi, fstep)
    validators = _validators(fields["validators"], source, name) if "validators" in fields else ()
    return ParameterDescriptor(
        name=name,
        type=ptype,
        description=text("description"),
        additional_constraints=text("additional_constraints"),
        read_only=flag("read_only"),
        dynamic_typing=flag("dynamic_typing"),
        integer_range=int_range,
        floating_point_range=fp_range,
        validators=validators,
    )


def _range(node: yaml.Node, source: Source, name: str, ptype: ParameterType) -> tuple[float, float, float]:
    value = typed_value(node, source, name, ptype).value
    assert isinstance(value, tuple)
    if len(value) != 3:
        raise source.error(f"parameter {name!r}: a range is [from, to, step]", node)
    lo, hi, step = value
    assert isinstance(lo, (int, float)) and isinstance(hi, (int, float)) and isinstance(step, (int, float))
    return lo, hi, step


def _validators(node: yaml.Node, source: Source, name: str) -> tuple[Validator, ...]:
    if not isinstance(node, yaml.SequenceNode):
        raise source.error(f"parameter {name!r}: validators must be a list like [- bounds: [0, 1]]", node)
    out = []
    for item in node.value:
        entries = list(items(expect_map(item, source, f"parameter {name!r} validator"), source, name))
        if len(entries) != 1:
            raise source.error(f"parameter {name!r}: each validator is one 'kind: [args]' entry", item)
        kind, knode, args = entries[0]
        out.append(parse_validator(kind, knode, args, source, name, None))
    return tuple(out)


def parse_validator(
    kind: str,
    knode: yaml.Node,
    args: yaml.Node,
    source: Source,
    name: str,
    arg_type: ParameterType | None,
) -> Validator:
    """A validator ``kind: [args]``; ``kind`` is in VALIDATOR_ARITY with that many args, or custom.

    ``args`` may be ``null``, ``~``, nothing or ``[]`` for validators without arguments; a bare
    scalar for a one-argument validator is wrapped in a list, as generate_parameter_library does
    (``fixed_size<>: 3`` is ``fixed_size<>: [3]``). Each argument is typed by the resolver (or as
    ``arg_type`` when given: see the spec format). A custom validator (``ns::fn``) takes any
    arguments, typed as written.
    """
    custom = "::" in kind
    if not custom and kind not in VALIDATOR_ARITY:
        known = ", ".join(f"{k}<>" for k in VALIDATOR_ARITY)
        raise source.error(
            f"parameter {name!r}: unknown validator {kind!r} (supported: {known}, or a custom ns::function)",
            knode,
        )
    arity = None if custom else VALIDATOR_ARITY[kind]
    if _is_null(args) or (
        isinstance(args, yaml.ScalarNode)
        and args.tag == PLAIN_TAG
        and args.value in ("null", "Null", "NULL", "~")
    ):
        arg_nodes: list[yaml.Node] = []
    elif isinstance(args, yaml.SequenceNode) and args.tag == SEQ_TAG:
        arg_nodes = list(args.value)
    elif isinstance(args, yaml.ScalarNode) and arity in (1, None):
        arg_nodes = [args]
    else:
        raise source.error(f"parameter {name!r}: arguments of {kind} must be a list like [a, b]", args)
    if arity is not None and len(arg_nodes) != arity:
        raise source.error(
            f"parameter {name!r}: validator {kind} takes {arity} argument(s), got {len(arg_nodes)}", args
        )
    values = []
    for a in arg_nodes:
        v = node_value(a, source, name, None if custom else arg_type)
        if isinstance(v, UntypedEmptyList):
            raise source.error(f"parameter {name!r}: validator {kind}: write an empty list with its type", a)
        values.append(v)
    return Validator(kind, tuple(values))


def _merge(
    sections: dict[str, _Section], node_id: str, source: Source
) -> list[tuple[str, ParameterValue, ParameterDescriptor | None]]:
    values: dict[str, tuple[_RawValue, int]] = {}
    descs: dict[str, tuple[ParameterDescriptor, int]] = {}
    for key, section in sections.items():
        if node_key_matches(key, node_id):
            values.update(section.values)
            descs.update(section.descriptors)
    out = []
    for name in sorted(values):
        raw, line = values[name]
        desc = descs.get(name, (None, 0))[0]
        out.append((name, _typed(name, raw, line, desc, source), desc))
    return out


def _typed(
    name: str, raw: _RawValue, line: int, desc: ParameterDescriptor | None, source: Source
) -> ParameterValue:
    dtype = desc.type if desc is not None and not desc.dynamic_typing else ParameterType.NOT_SET
    if isinstance(raw, UntypedEmptyList):
        if not dtype.is_array:
            raise FileFormatError(
                f"parameter {name!r}: an empty list [] has no type; write it as "
                "!integer_array [] (or !double_array, !string_array, !bool_array, !byte_array)",
                file=source.name,
                line=raw.line,
            )
        return ParameterValue.of(dtype, ())
    if dtype is ParameterType.NOT_SET or raw.type is dtype or raw.type is ParameterType.NOT_SET:
        return raw
    try:
        return raw.coerce(dtype, name=name)
    except ParamddsError as exc:
        raise FileFormatError(
            f"{exc.message} (descriptor type {dtype.label})", file=source.name, line=line
        ) from exc


def node_keys(text: str, *, source: str = "<string>") -> list[str]:
    """The node keys of a ROS 2 parameter file's sections, in file order (wildcards included)."""
    return list(_parse(text, Source(source)))


def load_ros_text_full(
    text: str, node_id: str, *, source: str = "<string>"
) -> list[tuple[str, ParameterValue, ParameterDescriptor | None]]:
    """Like :func:`load_ros_file_full` for text; ``source`` names it in errors."""
    src = Source(source)
    return _merge(_parse(text, src), node_id, src)


def load_ros_file_full(
    path: str | Path, node_id: str
) -> list[tuple[str, ParameterValue, ParameterDescriptor | None]]:
    """``(name, value, descriptor or None)`` for ``node_id``, sorted by name.

    Only sections whose key matches ``node_id`` apply, later ones winning (see the
    module rules). Raises :class:`~paramdds.errors.FileFormatError`.
    """
    return load_ros_text_full(read_file(path), node_id, source=str(path))


def load_ros_params_str(text: str, node_id: str, *, source: str = "<string>") -> dict[str, ParameterValue]:
    """Like :func:`load_ros_params` for text."""
    return {n: v for n, v, _ in load_ros_text_full(text, node_id, source=source)}


def load_ros_params(path: str | Path, node_id: str) -> dict[str, ParameterValue]:
    """The values a ROS 2 parameter file gives ``node_id`` (only its matching sections)."""
    return load_ros_params_str(read_file(path), node_id, source=str(path))
