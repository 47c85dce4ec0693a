"""``paramdds list``: the parameter names of a node, or of every node grouped by node, as
``ros2 param list`` does without a node (ROS list semantics: prefixes, depth)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...session import Session

HELP = "parameter names of a node (of every node without one)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "node", nargs="?", metavar="NODE", help="the node (default: every node online, grouped by node)"
    )
    p.add_argument("--prefix", action="append", dest="prefixes", default=[], metavar="P")
    p.add_argument("--depth", type=int, default=0, metavar="D", help="0: every level (default)")


def run(args: argparse.Namespace) -> int:
    from ...exits import Exit, UsageError
    from ...session import Session
    from .._output import emit
    from .._values import node_arg

    node = None if args.node is None else node_arg(args.node)
    if args.depth < 0:
        raise UsageError(f"--depth must be 0 (every level) or positive, got {args.depth}")
    with Session(args) as session:
        if node is None:
            every = every_node(session, args.prefixes, args.depth)
            lines = [f"{shown}:\n" + "".join(f"  {n}\n" for n in names) for shown, names in every.items()]
            emit(args.output, every, "".join(lines).rstrip("\n"))
            return Exit.OK
        result = session.client().list(node, args.prefixes, args.depth)
    names = sorted(result.names)
    emit(args.output, names, "\n".join(names))
    return Exit.OK


def every_node(session: Session, prefixes: list[str], depth: int) -> dict[str, list[str]]:
    """The names of every online node, by node in order (a ROS 2 node with its leading slash),
    from one monitor's state: no request per node."""
    from ...core.listing import list_names
    from ...core.names import shown_node
    from .._live import current_states

    states = current_states(session)
    return {
        shown_node(st.node, st.origin): list_names(sorted(st.parameters), prefixes, depth)[0]
        for st in sorted(states.values(), key=lambda st: st.node)
        if st.online
    }
