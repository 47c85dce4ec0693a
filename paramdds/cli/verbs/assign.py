"""``paramdds assign``: hold values for a node until Ctrl-C; they reach it whenever it starts.

The values are retained by this process's assignment writer (:class:`~paramdds.dds.assign.Assigner`);
a ``NAME=VALUE`` on the command line wins over the same name in ``--file``. Each time a
node applies them (when it starts, or at once) its answer is printed as it comes: one
line for the assignment and one per refused parameter with the node's reason (one JSON
object per answer with ``-o json``).
"""

from __future__ import annotations

import argparse
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...dds.client import SetReply

HELP = "hold values for a node; they reach it whenever it starts (until Ctrl-C)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("assignments", nargs="*", metavar="NAME=VALUE", help="values typed as YAML scalars")
    p.add_argument("--file", metavar="FILE", help="a parameter file with more values (command line wins)")


def run(args: argparse.Namespace) -> int:

    from ...core.values import Parameter
    from ...exits import Exit, UsageError
    from ...formats.files import read_values
    from ...session import Session
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
    printer = ReplyPrinter(args.output)
    with Session(args, app_name="paramdds-assign") as session:
        assigner = session.assigner(printer)  # keep it: its writer holds the retained values
        assigner.assign(node, list(params.values()))
        printer.write(f"[ASSIGN] holding {len(params)} parameters for node {node} (Ctrl-C to stop)")
        wait_until_interrupted()
    return Exit.OK


class ReplyPrinter:
    """Prints a node's answers to the assignment as they come (on the assigner's thread)."""

    def __init__(self, output: str) -> None:
        self._json = output == "json"
        self._lock = threading.Lock()

    def __call__(self, reply: SetReply, error: str) -> None:
        from .._output import dumps_json

        refused = [r for r in reply.results if not r.successful]
        if self._json:
            data: dict[str, object] = {"event": "assigned", "node": reply.node, "revision": reply.revision}
            if error:
                data["error"] = error
            data["results"] = {
                r.name: {"successful": r.successful, "reason": r.reason} for r in reply.results
            }
            self.write(dumps_json(data, pretty=False))
            return
        if error:
            self.write(f"[ASSIGN] node {reply.node} refused the assignment: {error}")
            return
        applied = len(reply.results) - len(refused)
        lines = [
            f"[ASSIGN] node {reply.node} applied {applied} of {len(reply.results)} parameters "
            f"(revision {reply.revision})"
        ]
        lines += [f"[ASSIGN]   {r.name}: FAILED: {r.reason}" for r in refused]
        self.write("\n".join(lines))

    def write(self, text: str) -> None:
        import sys

        with self._lock:
            sys.stdout.write(text + "\n")
            sys.stdout.flush()
