"""``paramdds assign``: hold values for a node until Ctrl-C; they reach it whenever it starts.

The values are retained by this process's assignment writer (:class:`~paramdds.dds.assign.Assigner`);
a ``NAME=VALUE`` on the command line wins over the same name in ``--file``.
"""

from __future__ import annotations

import argparse

HELP = "hold values for a node; they reach it whenever it starts (until Ctrl-C)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("assignments", nargs="*", metavar="NAME=VALUE", help="values typed as YAML scalars")
    p.add_argument("--file", metavar="FILE", help="a parameter file with more values (command line wins)")


def run(args: argparse.Namespace) -> int:
    import sys

    from ...core.values import Parameter
    from ...core.yaml.files import read_values
    from ...frontend.exits import Exit, UsageError
    from ...frontend.session import Session
    from .._live import wait_until_interrupted
    from .._values import node_arg, parse_assignments

    node = node_arg(args.node)
    params: dict[str, Parameter] = {}
    if args.file:
        params.update((p.name, p) for p in read_values(args.file, node))
    for a in parse_assignments(args.assignments):
        if a.value is None:
            raise UsageError(
                f"{a.name}: an empty list cannot be typed without the node; give it in --file with its type"
            )
        params[a.name] = Parameter(a.name, a.value)
    if not params:
        raise UsageError("nothing to assign: give NAME=VALUE arguments or --file")
    with Session(args, app_name="paramdds-assign") as session:
        assigner = session.assigner()  # keep it: its writer holds the retained values
        assigner.assign(node, list(params.values()))
        sys.stdout.write(f"[ASSIGN] holding {len(params)} parameters for node {node} (Ctrl-C to stop)\n")
        sys.stdout.flush()
        wait_until_interrupted()
    return Exit.OK
