"""Building a node's parameter table from its sources, and running a server process.

Sources, lowest precedence first (each later one overrides the values before it):

1. the spec's defaults (``--spec``, a generate_parameter_library file, or
   ``--schema``, a JSON Schema as Autoware writes them): it declares the parameters,
   with their descriptors and validators (a schema also checks the whole node on
   every change, see :mod:`paramdds.formats.schema`);
2. the parameter files (``--params-file``), in order: a file with a top-level
   ``parameters:`` list is a parameter list and applies to every hosted node;
   any other file is a ROS 2 parameter file and only the sections matching the
   node apply;
3. the persisted runtime values (``--persist``), and its record of parameters
   deleted at runtime, which stay deleted whatever the files and spec declare;
4. retained assignments, applied by the server once it runs.

Without a spec, the values of 2 and 3 declare the parameters (their type is the
type of the value; a persisted descriptor is kept). With a spec, a value for a
name the spec does not declare is declared only with ``--allow-undeclared``;
otherwise it is skipped with a warning naming it and the file.

A node's start is one commit: what the files (and ``--use-sim-time``) declare is revision
1, as what a spec declares with the files' values is. With a spec, what the files add
beyond it (``--allow-undeclared``) is one commit more, and so is each parameter deleted
at runtime (``--persist``) that the spec declares again, and ``--use-sim-time``.

A problem in a source is a :class:`~paramdds.errors.FileFormatError` naming the
file (and the line when the format knows it); the server does not start.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from typing import Any

from .core.descriptors import ParameterDescriptor
from .core.history import Retention
from .core.table import ParameterTable
from .core.values import ParameterType, ParameterValue
from .errors import FileFormatError, ParamddsError
from .formats.files import Entry, dump_text, parse_ros_text, read_entries
from .persist import PersistError, PersistStore

log = logging.getLogger(__name__)



# -- the spec -------------------------------------------------------------------------------


def _load_spec(path: str, strict: bool = False) -> Any:
    from .formats import spec as yaml_spec

    return yaml_spec.load_spec(path, strict=strict)


def _declare_spec(
    table: ParameterTable, spec: Any, values: Mapping[str, ParameterValue], options: ServerOptions
) -> None:
    from .formats import schema as yaml_schema
    from .formats import spec as yaml_spec

    if isinstance(spec, yaml_schema.NodeSchema):  # --schema: a JSON Schema declares the node
        for note in yaml_schema.declare_schema(table, spec, values, lenient=options.lenient):
            log.warning("%s: %s", options.schema, note)
        return
    yaml_spec.declare_spec(table, spec)


# -- building tables -------------------------------------------------------------------------


@dataclass
class ServerOptions:
    node_names: list[str]
    params_files: list[str] = field(default_factory=list)
    spec: str | None = None
    strict_spec: bool = False  # refuse a spec naming a custom validator nobody registered
    schema: str | None = None  # a JSON Schema (Autoware's) declaring the parameters, instead of a spec
    lenient: bool = False  # --schema: unknown keywords warn; file values it refuses are left out
    persist: str | None = None
    allow_undeclared: bool = False
    strict_types: bool = False
    read_only: bool = False
    use_sim_time: bool = False


@dataclass
class NodeSources:
    """Everything one node is built from, read and checked before anything starts."""

    node_id: str
    files: list[tuple[str, list[Entry]]]
    persisted: list[Entry]
    deleted: list[str] = field(default_factory=list)  # deleted at runtime (--persist): stay deleted


def build_table(
    sources: NodeSources,
    options: ServerOptions,
    spec: Any = None,
    *,
    with_persisted: bool = True,
) -> ParameterTable:
    """The node's table, its values layered as the module docstring says."""
    layers = [(path, entries) for path, entries in sources.files]
    if with_persisted and sources.persisted:
        layers.append((options.persist or "<persisted>", sources.persisted))
    values: dict[str, ParameterValue] = {}
    descriptors: dict[str, ParameterDescriptor | None] = {}
    origin: dict[str, str] = {}
    for path, entries in layers:
        for name, value, descriptor in entries:
            first = values.get(name)
            dynamic = any(d is not None and d.dynamic_typing for d in (descriptor, descriptors.get(name)))
            if first is not None and value.type is not first.type and not dynamic:
                value = _retype(name, value, first, path, options.strict_types)
            values[name] = value
            if descriptor is not None or name not in descriptors:
                descriptors[name] = descriptor
            origin[name] = path
    table = ParameterTable(
        sources.node_id,
        allow_undeclared=options.allow_undeclared,
        strict_types=options.strict_types,
        read_only=options.read_only,
        use_sim_time=options.use_sim_time and spec is not None,  # else one commit with the files'
        overrides=values,
    )
    gone = set(sources.deleted) if with_persisted else set()
    pending: list[Entry] = []
    if options.use_sim_time and spec is None:
        pending.append(("use_sim_time", ParameterValue.of(ParameterType.BOOL, False), None))
    if spec is not None:
        _declare_spec(table, spec, values, options)
        for name in sorted(gone & set(table.names())):
            try:
                table.undeclare(name)  # deleted at runtime: the spec allowed it then
            except ParamddsError as exc:  # the spec changed since: it wins
                log.warning("%s: %r was deleted at runtime, the spec keeps it: %s", options.spec, name, exc)
    for name, value in values.items():
        if table.has(name) or name in gone or any(name == p[0] for p in pending):
            continue
        if spec is not None and not options.allow_undeclared:
            log.warning(
                "%s: %r is not declared by the spec %s; skipped (use --allow-undeclared)",
                origin[name],
                name,
                options.spec or options.schema,
            )
            continue
        pending.append((name, value, descriptors.get(name)))
    _declare_all(table, pending, origin)
    return table


def _declare_all(table: ParameterTable, pending: list[Entry], origin: Mapping[str, str]) -> None:
    """Declare ``pending`` in one commit, so that a node the files declare starts at revision 1;
    when that is refused (nothing is declared then), the parameter at fault is found and
    raised as a FileFormatError naming the file that gave it."""
    try:
        table.declare_from(pending)
    except ParamddsError as whole:
        for name, value, descriptor in pending:
            try:
                table.declare(name, value, descriptor)
            except ParamddsError as exc:
                file = origin.get(name)
                raise FileFormatError(f"parameter {name!r}: {exc.message}", file=file) from exc
        raise whole


def _retype(
    name: str, value: ParameterValue, first: ParameterValue, path: str, strict: bool
) -> ParameterValue:
    """A later layer's value in the type an earlier layer gave ``name`` (FileFormatError if it cannot be)."""
    from .core.values import ParameterType

    if first.type is ParameterType.NOT_SET or value.type is ParameterType.NOT_SET:
        return value
    try:
        return value.coerce(first.type, strict=strict, name=name)
    except ParamddsError as exc:
        raise FileFormatError(exc.message, file=path) from exc


def persist_store(path: str) -> PersistStore:
    """The journal of ``--persist``, reading and writing ROS 2 parameter files."""
    return PersistStore(
        path, dumper=lambda state: dump_text(state, with_descriptors=True), parser=parse_ros_text
    )


def prepare(options: ServerOptions) -> tuple[dict[str, ParameterTable], list[str], PersistStore | None]:
    """Read every source and build every table; nothing touches DDS or the disk (but reads).

    Returns the tables, the ``[SERVER] Loaded ...`` lines and the persistence store.
    """
    spec = _load_spec(options.spec, options.strict_spec) if options.spec else None
    if options.schema:
        from .formats.schema import load_schema

        spec = load_schema(options.schema, lenient=options.lenient)
    store = persist_store(options.persist) if options.persist else None
    if store is not None:
        store.check_writable()
    tables: dict[str, ParameterTable] = {}
    loaded: dict[str, int] = {path: 0 for path in options.params_files}
    for node_id in options.node_names:
        files = [(path, read_entries(path, node_id)) for path in options.params_files]
        for path, entries in files:
            loaded[path] = max(loaded[path], len(entries))
        sources = NodeSources(
            node_id, files, store.read(node_id) if store else [], store.deleted(node_id) if store else []
        )
        build_table(sources, options, spec, with_persisted=False)  # blame the files first
        try:
            tables[node_id] = build_table(sources, options, spec)
        except ParamddsError as exc:  # a spec's declare raises TypeMismatchError & co., not FileFormatError
            if store is None:
                raise
            detail = exc.detail if isinstance(exc, FileFormatError) else exc.message
            raise PersistError(f"does not fit node {node_id!r}: {detail}", file=str(store.path)) from exc
    lines = [f"[SERVER] Loaded {count} parameters from {path}" for path, count in loaded.items()]
    return tables, lines, store


class ServerProcess:
    """The DDS side of ``paramdds server``: one participant hosting every table."""

    def __init__(
        self,
        tables: Mapping[str, ParameterTable],
        store: PersistStore | None,
        participant_factory: Callable[[], Any],
        qos: Any = None,
        *,
        retention: Retention | None = None,
    ) -> None:
        self.tables = dict(tables)
        self._retention = retention
        self.store = store
        self._participant_factory = participant_factory
        self._qos = qos
        self._server: Any = None

    def start(self) -> None:
        """Write the persistence file (so it exists), then host and serve every table."""
        from .dds.server import ParameterServer

        store = self.store
        if store is not None:
            if self._retention is not None:
                store.set_retention(self._retention)
            store.attach(self.tables)
        participant = self._participant_factory()
        server = ParameterServer(participant, self._qos, nodes=list(self.tables), retention=self._retention)
        if getattr(participant.transport, "grants", None) is not None:  # secure: who = the certificate
            from .secure.authenticated import authenticator_for

            server.authenticate = authenticator_for(participant)
        if store is not None:  # history and blame survive a restart; new records persist with their changes
            server.persisters.append(store.record)
            for node_id, table in self.tables.items():
                history = server.history(node_id)
                store.history(node_id).restore_into(history, table.names())
                history.add_listener(partial(store.recorded, node_id))
        for table in self.tables.values():
            server.add_node(table)
        if store is not None:
            store.write_history()  # the start values of parameters with no last change yet
        self._server = server.start()

    def close(self) -> None:
        """Graceful stop: monitors see the nodes offline, not their parameters deleted."""
        if self._server is not None:
            self._server.close()
            self._server = None
        if self.store is not None:
            self.store.close()  # releases the journal's lock
