"""``paramdds list``: the parameter names of a node (ROS list semantics: prefixes, depth)."""

from __future__ import annotations

import argparse

HELP = "parameter names of a node"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("--prefix", action="append", dest="prefixes", default=[], metavar="P")
    p.add_argument("--depth", type=int, default=0, metavar="D", help="0: every level (default)")


def run(args: argparse.Namespace) -> int:
    from ...exits import Exit, UsageError
    from ...session import Session
    from .._output import emit
    from .._values import node_arg

    node = node_arg(args.node)
    if args.depth < 0:
        raise UsageError(f"--depth must be 0 (every level) or positive, got {args.depth}")
    with Session(args) as session:
        result = session.client().list(node, args.prefixes, args.depth)
    names = sorted(result.names)
    emit(args.output, names, "\n".join(names))
    return Exit.OK
