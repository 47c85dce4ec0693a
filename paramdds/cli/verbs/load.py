"""``paramdds load``: set a node's parameters from a parameter file (seed or ROS 2 format)."""

from __future__ import annotations

import argparse

HELP = "set a node's parameters from a parameter file"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--atomic", action="store_true", help="all or nothing")


def run(args: argparse.Namespace) -> int:
    from ...core.yaml.files import read_values
    from ...frontend.exits import UsageError
    from ...frontend.session import Session
    from .._output import report_set
    from .._values import node_arg

    node = node_arg(args.node)
    params = read_values(args.file, node)
    if not params:
        raise UsageError(f"{args.file}: no parameters for node {node!r} in this file")
    with Session(args) as session:
        reply = session.client().set(node, params, atomic=args.atomic)
    return report_set(args.output, node, reply)
