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
is a dynamically typed parameter (descriptor type not_set, dynamic_typing), which
the library leaves to other code: without a default it is declared unset, not required.

**Leaf keys**: ``type`` (required), ``default_value``, ``description``,
``read_only``, ``additional_constraints``, ``validation``. Anything else is an
error, never ignored. A leaf without ``default_value`` is **required**: its
default is NOT_SET and :func:`declare_spec` needs a value for it from an
override. ``default_value`` must fit the type (integers widen to doubles; a
plain scalar for a string is taken as written; ``[]`` takes the array type).

**Mapped parameters** (``__map_<key>``, as generate_parameter_library defines
them): ``gains: {__map_joints: {p: {type: double}}}`` declares ``gains.<j>.p``
for every string ``<j>`` of the ``string_array`` parameter ``joints``, which the
same spec declares: ``gains.joints`` when it exists, else the root ``joints`` (the
library's ``get_dynamic_mapped_parameter``). Nested maps give every combination.
When the key array changes at runtime, the parameters of new entries are
declared (their default, or an override) right after the set that changed it;
those of removed entries stay declared, as the library's
``refresh_dynamic_parameters`` does ("TODO remove any destroyed dynamic
parameters"). An entry written twice in the array gives its parameters once.

**Validators** are spelled as that library does, ``name<>: [args]`` (the ``<>``
may be left out), with names from
:data:`~paramdds.core.descriptors.VALIDATOR_ARITY` and exactly that many
arguments (``null`` or ``[]`` for none): ``bounds<>: [0.0, 5.0]``, ``gt<>: [0]``,
``one_of<>: [["a", "b"]]``, ``unique<>: null``, ``size_gt<>: [2]``... A bare
argument of a one-argument validator is wrapped in a list, as the library does
(``fixed_size<>: 3``, ``gt_eq<>: 0.0``). Arguments
take the parameter's type (``bounds<>: [0, 5]`` on a double is ``0.0, 5.0``; the
list of ``one_of``/``subset_of`` is of the parameter's element type; sizes are
integers). A validator must suit its parameter (numeric bounds on numbers, sizes
on strings and arrays, ``unique``/``subset_of``/element bounds on arrays), and
combinations the library refuses are refused (``bounds`` with ``gt``/``gt_eq``/
``lt``/``lt_eq``; ``element_bounds`` with ``lower_element_bounds``/
``upper_element_bounds``). An unknown built-in name or a wrong number of arguments is an
error. A custom validator (``my_ns::check``) runs the function registered under
that name (:mod:`.custom_validators`); one nobody registered loads with a warning
naming it (``describe`` still lists it among the validators; ``additional_constraints``
is the spec's own text, as in generate_parameter_library), or is an error with
``strict=True`` (``--strict-spec``).

**Ranges.** The descriptor's integer/floating-point range (step 0) is filled from
the validators so ROS tools can show it, by generate_parameter_library's rules (its
``descriptor_test_gtest.cpp`` pins them): ``bounds`` gives ``[lo, hi]``; ``gt``,
``gt_eq`` and ``lower_bounds`` give the lower end, ``lt``, ``lt_eq`` and
``upper_bounds`` the upper end, each at the bound itself (a range is inclusive, so
for ``gt``/``lt`` the validator keeps the bound out); an open end is the type's limit
as the library's descriptor tests pin it (``std::numeric_limits<int64_t>`` for integers;
the lowest and largest double for doubles); on integer and double arrays the
element-bounds validators do the same for the elements.
"""

from __future__ import annotations

import itertools
import logging
import re
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import yaml

from ..core.custom_validators import lookup_validator
from ..core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from ..core.results import ChangeSet
from ..core.table import ParameterTable
from ..core.validation import check_validator
from ..core.values import INT64_MAX, INT64_MIN, NOT_SET, ParameterType, ParameterValue
from ..errors import InvalidValueError, ParamddsError
from .base import Source, compose, expect_map, items, read_file
from .ros import parse_validator
from .scalar import node_value, typed_value

__all__ = ["MappedEntry", "Spec", "SpecEntry", "declare_spec", "load_spec", "load_spec_str"]

log = logging.getLogger(__name__)
_MAP = "__map_"
# generate_parameter_library's descriptor_test_gtest.cpp (check_gt, check_lt_eq) pins the open end
# of an integer range at std::numeric_limits<int64_t>
_INT_MIN, _INT_MAX = INT64_MIN, INT64_MAX
_DBL_MAX = sys.float_info.max

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
        """No default, and not of type ``none`` (which other code sets: it starts unset)."""
        return self.default.type is ParameterType.NOT_SET and not self.descriptor.dynamic_typing


@dataclass(frozen=True, slots=True)
class MappedEntry:
    """A parameter under ``__map_<key>`` groups: ``entry.name`` holds the ``__map_<key>`` segments."""

    entry: SpecEntry
    keys: tuple[str, ...]  # the string_array parameters, outermost first
    line: int = 0  # of the leaf, for errors

    def expand(self, key_values: Sequence[Sequence[str]]) -> list[SpecEntry]:
        """One entry per combination of key values (``gains.__map_joints.p`` → ``gains.j1.p``…)."""
        out = []
        for combo in itertools.product(*(dict.fromkeys(v) for v in key_values)):
            parts = iter(combo)
            name = ".".join(
                next(parts) if seg.startswith(_MAP) else seg for seg in self.entry.name.split(".")
            )
            out.append(SpecEntry(name, self.entry.default, replace(self.entry.descriptor, name=name)))
        return out


class Spec(list[SpecEntry]):
    """The plain entries of a spec (a list, in file order), its mapped parameters and its
    custom validators that nobody registered (``unenforced``)."""

    def __init__(
        self,
        entries: Iterable[SpecEntry] = (),
        mapped: Iterable[MappedEntry] = (),
        unenforced: Iterable[str] = (),
    ) -> None:
        super().__init__(entries)
        self.mapped: tuple[MappedEntry, ...] = tuple(mapped)
        self.unenforced: tuple[str, ...] = tuple(unenforced)


_MapKeys = tuple[tuple[str, str], ...]  # per __map_ key: (the static group path above it, the key)


class _Walk:
    """What a walk over the spec collects."""

    def __init__(self, src: Source, strict: bool) -> None:
        self.src = src
        self.strict = strict
        self.entries: list[SpecEntry] = []
        self.mapped: list[tuple[SpecEntry, _MapKeys, int]] = []
        self.unenforced: dict[str, None] = {}


def load_spec_str(text: str, *, source: str = "<string>", strict: bool = False) -> Spec:
    """Like :func:`load_spec` for text; ``source`` names it in errors."""
    src = Source(source)
    root = compose(text, src, aliases=True)
    if root is None:
        raise src.error("the spec is empty; expected one namespace key holding the parameters")
    roots = list(items(expect_map(root, src, "top level"), src, "top level"))
    if len(roots) != 1:
        raise src.error(f"a spec has exactly one root key (the namespace), found {len(roots)}", root)
    body = roots[0][2]
    walk = _Walk(src, strict)
    _walk(expect_map(body, src, "namespace"), "", (), walk)
    types = {e.name: e.descriptor.type for e in walk.entries}
    mapped = [
        MappedEntry(entry, tuple(_resolve(entry, raw, types, src, line) for raw in keys), line)
        for entry, keys, line in walk.mapped
    ]
    for name in walk.unenforced:
        log.warning(
            "%s: custom validator %r is not registered and will NOT be enforced (register it with "
            "paramdds.core.custom_validators.register_validator or --validators MODULE; --strict-spec "
            "refuses the spec instead)",
            source,
            name,
        )
    return Spec(walk.entries, mapped, walk.unenforced)


def _resolve(
    entry: SpecEntry, raw: tuple[str, str], types: dict[str, ParameterType], src: Source, line: int
) -> str:
    """The array a ``__map_<key>`` names: ``<group>.<key>`` if the spec declares it, else ``<key>``.

    As generate_parameter_library's ``get_dynamic_mapped_parameter``: ``nested.__map_entries``
    uses ``nested.entries`` when declared, ``pid.__map_joints`` the root ``joints``.
    """
    group, key = raw
    for name in (f"{group}.{key}" if group else key, key):
        if types.get(name) is ParameterType.STRING_ARRAY:
            return name
    where = f"{group}.{key}' or '{key}" if group else key
    raise src.error(
        f"parameter {entry.name!r}: {_MAP}{key} needs a string_array parameter '{where}' "
        "declared by this spec (outside any map)",
        line=line,
    )


def load_spec(path: str | Path, *, strict: bool = False) -> Spec:
    """The parameters a spec file declares, in file order (rules in the module doc)."""
    return load_spec_str(read_file(path), source=str(path), strict=strict)


def _is_leaf(node: yaml.MappingNode) -> bool:
    return any(
        isinstance(k, yaml.ScalarNode) and k.value == "type" and isinstance(v, yaml.ScalarNode)
        for k, v in node.value
    )


def _walk(node: yaml.MappingNode, prefix: str, keys: _MapKeys, walk: _Walk) -> None:
    src = walk.src
    for key, knode, vnode in items(node, src, f"group {prefix!r}" if prefix else "namespace"):
        name = f"{prefix}.{key}" if prefix else key
        inner = keys
        if key.startswith(_MAP) and len(key) > len(_MAP):
            group = ".".join(seg for seg in prefix.split(".") if seg and not seg.startswith(_MAP))
            inner = (*keys, (group, key[len(_MAP) :]))
        elif key.startswith("__"):
            raise src.error(f"parameter {name!r}: {key!r} is not a parameter name nor {_MAP}<array>", knode)
        if not isinstance(vnode, yaml.MappingNode):
            raise src.error(f"parameter {name!r}: expected a map with 'type' (or a group of them)", vnode)
        if _is_leaf(vnode):
            if inner is not keys:
                raise src.error(
                    f"parameter {name!r}: a {_MAP}<array> key holds parameters, not a type", knode
                )
            entry = _leaf(name, vnode, walk)
            if inner:
                walk.mapped.append((entry, inner, knode.start_mark.line + 1))
            else:
                walk.entries.append(entry)
        else:
            _walk(vnode, name, inner, walk)


def _parse_type(name: str, node: yaml.ScalarNode, src: Source) -> tuple[ParameterType, int | None]:
    label = str(node.value)
    if label in _BASE_TYPES:
        return _BASE_TYPES[label], None
    m = _FIXED.match(label)
    if m is None:
        known = ", ".join([*_BASE_TYPES, "string_fixed_N", "<t>_array_fixed_N"])
        raise src.error(f"parameter {name!r}: unknown type {label!r} (known: {known})", node)
    return _BASE_TYPES[m.group(1)], int(m.group(2))


def _leaf(name: str, node: yaml.MappingNode, walk: _Walk) -> SpecEntry:
    src = walk.src
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
    validators = _validators(name, ptype, fields["validation"][1], walk) if "validation" in fields else []
    if fixed is not None:
        validators.append(Validator("size_lt", (ParameterValue(T.INTEGER, fixed + 1),)))
    int_range, fp_range = _ranges(ptype, validators)
    # generate_parameter_library takes additional_constraints from the spec's own key only; an
    # unregistered custom validator is reported by a warning (and refused with strict=True)
    constraints = text("additional_constraints")
    descriptor = ParameterDescriptor(
        name=name,
        type=ptype,
        description=text("description"),
        additional_constraints=constraints,
        read_only=read_only,
        dynamic_typing=dynamic,
        integer_range=int_range,
        floating_point_range=fp_range,
        validators=tuple(validators),
    )
    return SpecEntry(name, default, descriptor)


_EXCLUDES = {
    "bounds": ("gt", "gt_eq", "lt", "lt_eq"),
    "element_bounds": ("lower_element_bounds", "upper_element_bounds"),
}


def _validators(name: str, ptype: ParameterType, node: yaml.Node, walk: _Walk) -> list[Validator]:
    src = walk.src
    where = f"parameter {name!r} validation"
    out = []
    kinds: dict[str, yaml.Node] = {}
    for key, knode, args in items(expect_map(node, src, where), src, where):
        kind = key[:-2] if key.endswith("<>") else key
        if "::" in kind:
            if lookup_validator(kind) is None:
                if walk.strict:
                    raise src.error(
                        f"parameter {name!r}: custom validator {kind!r} is not registered "
                        "(register it, or leave out --strict-spec to load it unenforced)",
                        knode,
                    )
                walk.unenforced[kind] = None
            out.append(parse_validator(kind, knode, args, src, name, None))
            continue
        arg_type = _arg_type(name, kind, ptype, knode, src)
        validator = parse_validator(kind, knode, args, src, name, arg_type)
        try:
            check_validator(ptype, validator)
        except ParamddsError as exc:
            raise src.error(f"parameter {name!r}: {exc.message}", knode) from None
        out.append(validator)
        kinds[kind] = knode
    for kind, excluded in _EXCLUDES.items():
        for other in excluded:
            if kind in kinds and other in kinds:
                raise src.error(
                    f"parameter {name!r}: validator {kind}<> cannot be combined with {other}<> "
                    "(generate_parameter_library refuses it)",
                    kinds[other],
                )
    return out


def _ranges(
    ptype: ParameterType, validators: Sequence[Validator]
) -> tuple[IntegerRange | None, FloatingPointRange | None]:
    """The descriptor range the validators imply (see "Ranges" in the module doc)."""
    lower_kinds: tuple[str, ...]
    upper_kinds: tuple[str, ...]
    if ptype in (T.INTEGER, T.DOUBLE):
        lower_kinds, upper_kinds = ("gt", "gt_eq", "lower_bounds"), ("lt", "lt_eq", "upper_bounds")
        both, number = "bounds", ptype
    elif ptype in (T.INTEGER_ARRAY, T.DOUBLE_ARRAY):
        lower_kinds, upper_kinds = ("lower_element_bounds",), ("upper_element_bounds",)
        both = "element_bounds"
        number = T.INTEGER if ptype is T.INTEGER_ARRAY else T.DOUBLE
    else:
        return None, None
    is_int = number is T.INTEGER
    lo: float | int | None = None
    hi: float | int | None = None
    for v in validators:
        args = [a.value for a in v.args]
        if not all(isinstance(a, (int, float)) and not isinstance(a, bool) for a in args):
            continue
        nums: list[float | int] = [a for a in args if isinstance(a, (int, float))]
        if v.kind == both:
            lo, hi = _tighter(lo, nums[0], True), _tighter(hi, nums[1], False)
        elif v.kind in lower_kinds:
            lo = _tighter(lo, nums[0], True)
        elif v.kind in upper_kinds:
            hi = _tighter(hi, nums[0], False)
    if lo is None and hi is None:
        return None, None
    if is_int:
        ilo = _INT_MIN if lo is None else int(lo)
        return IntegerRange(ilo, _INT_MAX if hi is None else int(hi)), None
    flo = -_DBL_MAX if lo is None else float(lo)
    return None, FloatingPointRange(flo, _DBL_MAX if hi is None else float(hi))


def _tighter(current: float | int | None, bound: float | int, lower: bool) -> float | int:
    if current is None:
        return bound
    return max(current, bound) if lower else min(current, bound)


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
    refusal by the table is raised as the table raised it. The mapped parameters of a
    :class:`Spec` are declared for the key arrays' values (override or default), and
    again for new entries whenever a key array changes (see the module doc).
    """
    plain = list(entries)
    mapped = entries.mapped if isinstance(entries, Spec) else ()
    expanded = _expand(mapped, lambda key: _start_value(table, plain, key))
    everything = plain + expanded
    missing = [e.name for e in everything if e.required and not table.has_override(e.name)]
    if missing:
        raise InvalidValueError(
            "required parameters have no value (give them in a parameter file or as overrides): "
            + ", ".join(repr(n) for n in missing)
        )
    table.declare_from([(e.name, e.default, e.descriptor) for e in everything])
    if mapped:
        table.add_commit_hook(_Refresher(table, mapped))


def _start_value(table: ParameterTable, plain: Sequence[SpecEntry], key: str) -> ParameterValue:
    override = table.override(key)
    if override is not None:
        return override
    return next((e.default for e in plain if e.name == key), NOT_SET)


def _expand(mapped: Sequence[MappedEntry], value_of: Callable[[str], ParameterValue]) -> list[SpecEntry]:
    out: list[SpecEntry] = []
    for m in mapped:
        key_values = []
        for key in m.keys:
            v = value_of(key)
            strings = v.value if v.type is T.STRING_ARRAY else ()
            assert isinstance(strings, tuple)
            key_values.append([str(x) for x in strings])
        out.extend(m.expand(key_values))
    return out


class _Refresher:
    """After a commit that changes a key array, declare the mapped parameters of its new entries."""

    def __init__(self, table: ParameterTable, mapped: Sequence[MappedEntry]) -> None:
        self.table = table
        self.mapped = tuple(mapped)
        self.keys = frozenset(k for m in mapped for k in m.keys)

    def __call__(self, change: ChangeSet) -> None:
        if not any(c.name in self.keys for c in change.changes):
            return
        table = self.table

        def value_of(key: str) -> ParameterValue:
            return table.get_many([key])[0].value or NOT_SET

        new = [e for e in _expand(self.mapped, value_of) if not table.has(e.name)]
        if new:
            table.declare_from([(e.name, e.default, e.descriptor) for e in new])
