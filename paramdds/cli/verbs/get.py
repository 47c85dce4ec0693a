"""``paramdds get``: values of parameters; a name the node lacks is one line on stderr and exit 1."""

from __future__ import annotations

import argparse

HELP = "values of parameters"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("names", nargs="+", metavar="NAME")


def run(args: argparse.Namespace) -> int:
    from ...core.jsonform import json_value
    from ...session import Session
    from .._output import emit, report_missing, typed
    from .._values import names_arg, node_arg

    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().get(node, names_arg(args.names))
    found = [r for r in reply.results if r.code is None]
    emit(
        args.output,
        {r.name: json_value(r.value) for r in found},
        "\n".join(f"{r.name} = {typed(r.value)}" for r in found),
    )
    return report_missing(node, reply.missing())
