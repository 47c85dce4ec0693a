"""``paramdds describe``: descriptors of parameters; a name the node lacks: one line on stderr, exit 1."""

from __future__ import annotations

import argparse

HELP = "descriptors of parameters"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("names", nargs="+", metavar="NAME")


def run(args: argparse.Namespace) -> int:
    from ...core.jsonform import json_descriptor
    from ...session import Session
    from .._output import describe_table, emit, report_missing
    from .._values import names_arg, node_arg

    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().get(node, names_arg(args.names), with_descriptors=True)
    found = {r.name: json_descriptor(r.descriptor) for r in reply.results if r.descriptor is not None}
    emit(args.output, found, describe_table(found))
    return report_missing(node, reply.missing())
