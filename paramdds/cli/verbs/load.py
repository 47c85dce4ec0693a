"""``paramdds load``: set a node's parameters from a parameter file (a parameter list or a ROS 2 file).

Only the values that differ from the node's are sent (:mod:`paramdds.file_load`): a
node's own dump loads back as a no-op, each value reported ``unchanged``.
"""

from __future__ import annotations

import argparse

HELP = "set a node's parameters from a parameter file"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--atomic", action="store_true", help="all or nothing")


def run(args: argparse.Namespace) -> int:
    from ...core.origin import Via
    from ...exits import UsageError
    from ...file_load import load
    from ...formats.files import read_values
    from ...session import Session
    from .._output import report_set
    from .._values import node_arg

    node = node_arg(args.node)
    params = read_values(args.file, node)
    if not params:
        raise UsageError(f"{args.file}: no parameters for node {node!r} in this file")
    with Session(args) as session:
        reply = load(session.client(Via.LOAD), node, params, atomic=args.atomic)
    return report_set(args.output, node, reply)
