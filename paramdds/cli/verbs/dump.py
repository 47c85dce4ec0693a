"""``paramdds dump``: a node's parameters as a ROS 2 parameter file on stdout (what ``load`` reads)."""

from __future__ import annotations

import argparse

HELP = "a node's parameters as a ROS 2 parameter file on stdout"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("--descriptors", action="store_true", help="add the descriptors (a map ROS 2 cannot read)")
    p.add_argument("--no-descriptors", action="store_true", help=argparse.SUPPRESS)  # the default now


def run(args: argparse.Namespace) -> int:
    import sys

    from ...core.yaml.files import dump_text
    from .._output import report_missing
    from .._snapshot import node_snapshot
    from .._values import node_arg

    node = node_arg(args.node)
    snapshot, missing = node_snapshot(args, node)
    sys.stdout.write(dump_text({node: snapshot}, with_descriptors=args.descriptors))
    sys.stdout.flush()
    return report_missing(node, missing)
