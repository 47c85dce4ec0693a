"""``paramdds delete``: delete (undeclare) parameters; one result per name, exit 1 if any was refused."""

from __future__ import annotations

import argparse

HELP = "delete (undeclare) parameters"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("names", nargs="+", metavar="NAME")


def run(args: argparse.Namespace) -> int:
    from ...session import Session
    from .._output import report_set
    from .._values import names_arg, node_arg

    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().delete(node, names_arg(args.names))
    return report_set(args.output, node, reply)
