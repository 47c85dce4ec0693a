"""The request verbs: nodes, list, get, describe, set, delete, dump, load.

Each parses and checks its local input first (exit 2 before anything is sent),
then opens a :class:`~paramdds.cli._session.Session`, asks, and prints. A reply
that refuses or lacks something prints what did succeed on stdout, one line per
problem on stderr, and exits 1.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..core.descriptors import ParameterDescriptor
from ..core.revision import Revision, incarnation_text
from ..core.values import Parameter, ParameterType
from ..errors import ParamddsError
from ._errors import Exit, UsageError, one_line
from ._output import describe_table, emit, json_descriptor, json_value, results_table, typed
from ._session import Session
from ._values import Assignment, fit_to_type, needs_descriptor, parse_assignments

if TYPE_CHECKING:
    from ..dds.client import ParameterClient, SetReply

log = logging.getLogger(__name__)

NODES_SETTLE = 2.0  # seconds `nodes` waits at most for the monitor to hold every node's state


def node_arg(text: str) -> str:
    """A node id from the command line, canonical (UsageError when invalid)."""
    from ..core.names import canonical_node_id

    try:
        return canonical_node_id(text)
    except ParamddsError as exc:
        raise UsageError(f"invalid node name {text!r}: {exc.message}") from exc


def problem(message: str) -> None:
    """One line on stderr about one thing that failed."""
    sys.stderr.write(f"paramdds: error: {one_line(message)}\n")


# -- nodes ------------------------------------------------------------------------------


def run_nodes(args: argparse.Namespace) -> int:
    from ._live import settle

    last = [time.monotonic()]
    with Session(args) as session:
        started = time.monotonic()
        monitor = session.monitor(on_event=lambda _e: last.__setitem__(0, time.monotonic()))
        if not settle(monitor, started, min(args.timeout, NODES_SETTLE), lambda: last[0]):
            log.warning("the node list may be incomplete: discovery did not settle in time")
        states = monitor.snapshot()
    rows: list[dict[str, object]] = [
        {
            "node": st.node,
            "online": st.online,
            "parameters": st.announced if st.announced >= 0 else len(st.parameters),
            "host": st.host,
            "pid": st.pid,
            "revision": st.revision,
            "also_hosted_by": list(st.duplicates),  # other processes hosting the same node id
            "request_filter": st.request_filter,  # "native", "handler", or None: the server does not say
            "incarnation": incarnation_text(st.incarnation),  # the server's for the node, new on every start
            "at": str(Revision(st.incarnation, st.revision)),  # what `set --if-revision` takes
            "origin": st.origin,  # the presence tag "origin" ("ros2": mirrored by the bridge), or None
            "status": st.status,  # "unreachable": a ROS 2 node the bridge cannot read; else None
        }
        for st in sorted(states.values(), key=lambda st: st.node)
        if st.online
    ]
    emit(args.output, rows, _nodes_table(rows))
    return Exit.OK


def _nodes_table(rows: list[dict[str, object]]) -> str:
    header = ("NODE", "ONLINE", "PARAMS", "HOST", "PID", "REVISION")
    cells = [header] + [
        (
            str(r["node"]),
            str(r["status"] or ("yes" if r["online"] else "no")),
            str(r["parameters"]),
            str(r["host"]),
            str(r["pid"]),
            str(r["revision"]),
        )
        for r in rows
    ]
    widths = [max(len(row[i]) for row in cells) for i in range(len(header))]
    lines = ("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells)
    return "\n".join(line.rstrip() for line in lines)


# -- list, get, describe --------------------------------------------------------------------


def run_list(args: argparse.Namespace) -> int:
    node = node_arg(args.node)
    if args.depth < 0:
        raise UsageError(f"--depth must be 0 (every level) or positive, got {args.depth}")
    with Session(args) as session:
        result = session.client().list(node, args.prefixes, args.depth)
    names = sorted(result.names)
    emit(args.output, names, "\n".join(names))
    return Exit.OK


def run_get(args: argparse.Namespace) -> int:
    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().get(node, args.names)
    found = [r for r in reply.results if r.code is None]
    emit(
        args.output,
        {r.name: json_value(r.value) for r in found},
        "\n".join(f"{r.name} = {typed(r.value)}" for r in found),
    )
    return _report_missing(node, reply.missing())


def run_describe(args: argparse.Namespace) -> int:
    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().get(node, args.names, with_descriptors=True)
    found = {r.name: json_descriptor(r.descriptor) for r in reply.results if r.descriptor is not None}
    emit(args.output, found, describe_table(found))
    return _report_missing(node, reply.missing())


def _report_missing(node: str, missing: Sequence[object]) -> int:
    for r in missing:
        problem(getattr(r, "reason", "") or f"{getattr(r, 'name', '?')}: not found on {node!r}")
    return Exit.REFUSED if missing else Exit.OK


# -- set, delete, load ------------------------------------------------------------------------


def run_set(args: argparse.Namespace) -> int:
    node = node_arg(args.node)
    assignments = parse_assignments(args.assignments)
    if_revision = None
    if args.if_revision is not None:
        try:
            if_revision = Revision.parse(args.if_revision)
        except ParamddsError as exc:
            raise UsageError(f"--if-revision: {exc.message}") from exc
    with Session(args) as session:
        client = session.client()
        params = typed_parameters(client, node, assignments)
        # a bare revision compares the revision alone (incarnation 0 on the wire)
        expected = if_revision.revision if if_revision and not if_revision.incarnation else if_revision
        reply = client.set(node, params, atomic=args.atomic, if_revision=expected)
    return report_set(args.output, node, reply)


def typed_parameters(
    client: ParameterClient, node: str, assignments: Sequence[Assignment]
) -> list[Parameter]:
    """Parameters ready to send; asks the node for the types an empty or integer list needs."""
    ask = [a.name for a in assignments if needs_descriptor(a)]
    types: dict[str, ParameterType | None] = {}
    if ask:
        reply = client.get(node, ask, with_descriptors=True)
        for r in reply.results:
            if r.value is None:
                types[r.name] = None
            elif r.descriptor is not None and r.descriptor.type is not ParameterType.NOT_SET:
                types[r.name] = r.descriptor.type
            else:
                types[r.name] = r.value.type
    return [Parameter(a.name, fit_to_type(a, types.get(a.name))) for a in assignments]


def run_delete(args: argparse.Namespace) -> int:
    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().delete(node, args.names)
    return report_set(args.output, node, reply)


def run_load(args: argparse.Namespace) -> int:
    from ..runtime import read_values

    node = node_arg(args.node)
    params = read_values(args.file, node)
    if not params:
        raise UsageError(f"{args.file}: no parameters for node {node!r} in this file")
    with Session(args) as session:
        reply = session.client().set(node, params, atomic=args.atomic)
    return report_set(args.output, node, reply)


def report_set(output: str, node: str, reply: SetReply) -> int:
    """Print a set/delete/load reply; exit 1 when any parameter failed."""
    results: dict[str, dict[str, object]] = {
        r.name: {"successful": r.successful, "reason": r.reason} for r in reply.results
    }
    data: dict[str, object] = {**results, "revision": reply.revision}
    emit(output, data, results_table(results, reply.revision))
    failed = [r for r in reply.results if not r.successful]
    if failed:
        problem(
            f"{len(failed)} of {len(reply.results)} parameters refused by node {node!r}: "
            + "; ".join(f"{r.name}: {r.reason}" for r in failed)
        )
        return Exit.REFUSED
    return Exit.OK


# -- dump -------------------------------------------------------------------------------------


def run_dump(args: argparse.Namespace) -> int:
    from ..runtime import dump_text

    node = node_arg(args.node)
    with Session(args) as session:
        client = session.client()
        names = client.list(node).names
        reply = client.get(node, list(names), with_descriptors=True)
    snapshot = [
        (r.name, r.value, r.descriptor or ParameterDescriptor(r.name, r.value.type))
        for r in reply.results
        if r.value is not None
    ]
    sys.stdout.write(dump_text({node: snapshot}, with_descriptors=args.descriptors))
    sys.stdout.flush()
    return _report_missing(node, reply.missing())
