"""``paramdds describe``: descriptors of parameters with their last change; a name the node
lacks: one line on stderr, exit 1."""

from __future__ import annotations

import argparse

HELP = "descriptors of parameters, and who last changed them"


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
    found = {
        r.name: {
            **json_descriptor(r.descriptor),
            # who last changed it, when, through what; null when the node does not say
            "last_change": None if r.last_change is None else r.last_change.to_json(),
        }
        for r in reply.results
        if r.descriptor is not None
    }
    emit(args.output, found, describe_table(found))
    return report_missing(node, reply.missing())
