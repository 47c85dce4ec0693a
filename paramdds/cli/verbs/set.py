"""``paramdds set``: set parameters, each on its own or ``--atomic``, optionally only at a revision.

Local input is checked first (exit 2 before anything is sent). An empty list or an
integer list takes its type from the node's descriptor (asked first, see
:mod:`paramdds.cli._values`); everything else the node types and checks itself.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...core.replies import SetReply
    from ...core.values import Parameter
    from ...dds.client import ParameterClient
    from .._values import Assignment

HELP = "set parameters (each on its own, or --atomic)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument(
        "assignments",
        nargs="+",
        metavar="NAME=VALUE",
        help="values typed as YAML scalars; NAME:=VALUE too, and NAME VALUE for one (as ros2 param set)",
    )
    p.add_argument("--atomic", action="store_true", help="all or nothing")
    p.add_argument(
        "--if-revision",
        metavar="[INCARNATION:]N",
        help="apply only while the node is still at that state: INCARNATION:N (the 'at' of "
        "`paramdds nodes -o json`) also fails after a restart; a bare N compares the revision alone",
    )


def run(args: argparse.Namespace) -> int:
    from ...core.revision import Revision
    from ...errors import ParamddsError
    from ...exits import UsageError
    from ...session import Session
    from .._output import report_set
    from .._values import node_arg, parse_assignments

    node = node_arg(args.node)
    assignments = parse_assignments(args.assignments, pair=True)
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
        reply = with_quote_hints(client, node, assignments, reply)
    return report_set(args.output, node, reply)


def with_quote_hints(
    client: ParameterClient, node: str, assignments: Sequence[Assignment], reply: SetReply
) -> SetReply:
    """``reply`` with a hint on how to quote each unquoted word (``on``, ``yes``, ``1.50``) that
    a string parameter refused for its type; the node's descriptors are asked only then."""
    from dataclasses import replace

    from ...core.values import ParameterType
    from ...errors import ErrorCode, ParamddsError
    from .._values import quote_hint, read_as_other_than_text

    given = {a.name: a for a in assignments if read_as_other_than_text(a)}
    refused = [r.name for r in reply.results if r.code is ErrorCode.TYPE_MISMATCH and r.name in given]
    if not refused:
        return reply
    try:
        described = client.get(node, refused, with_descriptors=True).results
    except ParamddsError:  # the set's own report matters more than the hint
        return reply
    strings = {
        d.name for d in described if d.descriptor is not None and d.descriptor.type is ParameterType.STRING
    }
    results = tuple(
        replace(r, reason=f"{r.reason}; {quote_hint(given[r.name])}") if r.name in strings else r
        for r in reply.results
    )
    return replace(reply, results=results)


def typed_parameters(
    client: ParameterClient, node: str, assignments: Sequence[Assignment]
) -> list[Parameter]:
    """Parameters ready to send; asks the node for the types an empty or integer list needs."""
    from ...core.values import Parameter, ParameterType
    from .._values import fit_to_type, needs_descriptor

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
