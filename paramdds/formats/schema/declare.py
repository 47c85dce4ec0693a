"""Declaring a JSON Schema's parameters on a table, and installing it as the node's validator."""

from __future__ import annotations

import logging
from collections.abc import Mapping

from ...core.table import ParameterTable
from ...core.values import NOT_SET, ParameterType, ParameterValue
from ...errors import FileFormatError, ParamddsError
from .describe import SchemaEntry
from .enforce import NodeSchema, Violation, concerns

__all__ = ["declare_schema"]

log = logging.getLogger(__name__)
T = ParameterType


def declare_schema(
    table: ParameterTable,
    schema: NodeSchema,
    values: Mapping[str, ParameterValue] | None = None,
    *,
    lenient: bool = False,
) -> list[str]:
    """Declare the schema's parameters on ``table`` (overrides given to the table win, as
    with a spec) and install the schema as its whole-node validator.

    ``values`` are every value the parameter files give (those the schema does not declare
    count too: ``additionalProperties: false`` refuses them). A parameter the files do
    not give takes the schema's default, unless that default is what makes the node
    invalid (``default`` is only an annotation in JSON Schema: a ``oneOf`` branch may
    need the parameter absent); it is then declared without a value. When the file
    values break the schema, nothing is declared and a FileFormatError names each
    violation; with ``lenient`` the file values at fault are left out instead and the
    returned lines say so.
    """
    given = dict(values or {})
    for name, exc in schema.ref_errors.items():
        if name in given or any(n.startswith(name + ".") for n in given):
            raise exc  # the reference is needed now
    declared = {e.name: e for e in schema.entries}
    chosen: dict[str, ParameterValue] = {}
    for e in schema.entries:
        override = table.override(e.name)
        chosen[e.name] = e.default if override is None else override
    from_file = {n for n in declared if table.has_override(n)}
    changed: set[str] = set()  # declared with another value than the table would choose
    notes: list[str] = []
    for _ in range(2 * len(declared) + 1):
        state = {**{n: v for n, v in given.items() if n not in declared}, **chosen}
        state = {n: _as_stored(v, declared.get(n), n) for n, v in state.items()}
        found = [v for v in schema.violations(state)]
        if not found:
            break

        def concerned(name: str, found: list[Violation] = found) -> bool:
            return any(v.path and concerns(v.path, name) for v in found)

        defaults = [n for n, v in chosen.items() if n not in from_file and v.type is not T.NOT_SET]
        unset = [n for n in defaults if concerned(n)]
        if unset:
            for name in unset:
                chosen[name] = NOT_SET
                changed.add(name)
                log.info("%s: %r starts without a value: its default breaks the schema", schema.file, name)
            continue
        at_fault = [n for n in sorted(from_file) if concerned(n)]
        if not lenient or not at_fault:
            lines = "; ".join(str(v) for v in found)
            raise FileFormatError(f"the parameters break the schema: {lines}", file=schema.file)
        for name in at_fault:
            from_file.discard(name)
            chosen[name] = declared[name].default
            changed.add(name)
            why = "; ".join(str(v) for v in found if concerns(v.path, name))
            notes.append(f"--lenient: {name!r} starts without the file's value ({why})")
    else:  # pragma: no cover - each name changes at most twice
        raise FileFormatError("the parameters break the schema", file=schema.file)
    table.declare_from([(e.name, e.default, e.descriptor) for e in schema.entries if e.name not in changed])
    for e in schema.entries:
        if e.name in changed:
            table.declare(e.name, chosen[e.name], e.descriptor, ignore_override=True)
    table.set_node_validator(schema.node_validator())
    return notes


def _as_stored(value: ParameterValue, entry: SchemaEntry | None, name: str) -> ParameterValue:
    """A file value as the table stores it (an integer for a double parameter is widened)."""
    if entry is None or entry.descriptor.dynamic_typing or value.type is T.NOT_SET:
        return value
    try:
        return value.coerce(entry.descriptor.type, name=name)
    except ParamddsError:
        return value  # the table refuses it when it is declared, with the type's reason
