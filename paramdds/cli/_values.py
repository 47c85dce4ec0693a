"""Node ids and ``NAME=VALUE`` arguments: split, typed from YAML scalars, checked before anything is sent.

``NAME:=VALUE`` is accepted too, and ``NAME VALUE`` for one parameter, as ``ros2 param`` users type them.

Values are typed by the same resolver as parameter files (it mirrors rcl):
``1`` is an integer, ``1.5`` a double, ``true`` a bool, ``[1, 2]`` an integer
array, ``"on"`` quoted stays a string. Where that is ambiguous the node decides:
``50`` for a double parameter widens there (unless the node uses strict types).

Two cases need the node's descriptor first and are resolved by
:func:`needs_descriptor` / :func:`fit_to_type`: an empty list ``[]`` (no element
type of its own) and an integer list for a byte_array parameter (the rule is
:mod:`paramdds.core.fit`, which the web console and the ROS 2 bridge use too).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from ..core.values import ParameterType, ParameterValue
from ..errors import NotFoundError, ParamddsError
from ..exits import UsageError

_EMPTY_LIST = re.compile(r"^\s*\[\s*\]\s*$")


@dataclass(frozen=True)
class Assignment:
    """One parsed ``NAME=VALUE``; ``value`` is None for an empty list awaiting its type."""

    name: str
    text: str
    value: ParameterValue | None


def node_arg(text: str) -> str:
    """A node id from the command line, canonical (UsageError when invalid)."""
    from ..core.names import canonical_node_id

    try:
        return canonical_node_id(text)
    except ParamddsError as exc:
        raise UsageError(f"invalid node name {text!r}: {exc.message}") from exc


def node_glob_arg(text: str) -> str:
    """A node id or a node glob (``fleet/*``, ``s1/*`` over Zenoh) from the command line
    (UsageError when invalid)."""
    from ..core.names import canonical_node_glob, is_node_glob

    if not is_node_glob(text):
        return node_arg(text)
    try:
        return canonical_node_glob(text)
    except ParamddsError as exc:
        raise UsageError(exc.message) from exc


def names_arg(names: Sequence[str]) -> list[str]:
    """Parameter names from the command line, checked (UsageError, exit 2, as for a bad node name)."""
    from ..core.names import validate_name

    for name in names:
        try:
            validate_name(name)
        except ParamddsError as exc:
            raise UsageError(f"invalid parameter name {name!r}: {exc.message}") from exc
    return list(names)


def parse_value(text: str) -> ParameterValue:
    """A command-line value typed like a YAML scalar (UsageError when unparsable)."""
    from ..formats.scalar import parse_cli_value

    try:
        return parse_cli_value(text)
    except ParamddsError as exc:
        raise UsageError(f"cannot parse value {text!r}: {exc.message}") from exc


def parse_assignment(arg: str) -> Assignment:
    """``NAME=VALUE`` → :class:`Assignment` (UsageError with the argument when malformed)."""
    from ..core.names import validate_name

    name, sep, text = arg.partition("=")
    name = name.strip()
    if name.endswith(":"):  # NAME:=VALUE, as ROS 2 command lines write it
        name = name[:-1].rstrip()
    if not sep or not name:
        raise UsageError(f"expected NAME=VALUE, got {arg!r}")
    try:
        validate_name(name)
    except ParamddsError as exc:
        raise UsageError(f"invalid parameter name in {arg!r}: {exc.message}") from exc
    if _EMPTY_LIST.match(text):
        return Assignment(name, text, None)
    try:
        value = parse_value(text)
    except UsageError as exc:
        raise UsageError(f"{name}: {exc}") from exc
    return Assignment(name, text, value)


def parse_assignments(args: Sequence[str], *, pair: bool = False) -> list[Assignment]:
    """Every argument parsed; a name given twice is a usage error.

    With ``pair``, two arguments of which the first has no ``=`` are one ``NAME VALUE``
    (``ros2 param set NODE NAME VALUE``)."""
    if pair and len(args) == 2 and "=" not in args[0]:
        args = [f"{args[0]}={args[1]}"]
    parsed = [parse_assignment(a) for a in args]
    seen: set[str] = set()
    for a in parsed:
        if a.name in seen:
            raise UsageError(f"parameter {a.name!r} is given twice")
        seen.add(a.name)
    return parsed


def read_as_other_than_text(a: Assignment) -> bool:
    """True when an unquoted scalar was typed other than a string (``on`` is a bool, ``1.50``
    a double, as in ROS 2): a string parameter refuses it, and quoting it sends the text."""
    unquoted = a.text.strip()[:1] not in ("'", '"')
    scalars = (ParameterType.BOOL, ParameterType.INTEGER, ParameterType.DOUBLE)
    return unquoted and a.value is not None and a.value.type in scalars


def quote_hint(a: Assignment) -> str:
    """How to send ``a``'s text as a string (for :func:`read_as_other_than_text`)."""
    text = a.text.strip()
    label = a.value.type.label if a.value is not None else "value"
    return f"{text!r} is read as a {label}; quote it to send the string: {a.name}='\"{text}\"'"


def needs_descriptor(a: Assignment) -> bool:
    """True when the node's type decides this value (empty list, integer list)."""
    return a.value is None or a.value.type is ParameterType.INTEGER_ARRAY


def fit_to_type(a: Assignment, target: ParameterType | None) -> ParameterValue:
    """The value of ``a`` for a parameter of type ``target`` (None: the node lacks it).

    An empty list takes the parameter's array type; an integer list becomes a byte
    array for a byte_array parameter (:func:`paramdds.core.fit.fit_value`). Everything
    else is left to the node, widening included (it refuses it under ``--strict-types``).
    """
    from ..core.descriptors import ParameterDescriptor
    from ..core.fit import EMPTY_LIST, fit_value

    if a.value is None and target is None:
        raise NotFoundError(f"cannot type the empty list for {a.name!r}: the node does not declare it")
    descriptor = None if target is None else ParameterDescriptor(a.name, target)
    if a.value is None:
        return fit_value(a.name, EMPTY_LIST, descriptor, widen=False)
    try:
        return fit_value(a.name, a.value, descriptor, widen=False)
    except ParamddsError as exc:
        raise UsageError(f"{a.name}: {exc.message}") from exc
