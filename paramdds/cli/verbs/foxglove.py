"""``paramdds foxglove``: the server is :mod:`paramdds.foxglove`'s; this verb checks the extra and runs it."""

from __future__ import annotations

import argparse

HELP = "every node's parameters in Foxglove and Lichtblick over WebSocket (needs the foxglove extra)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "nodes",
        nargs="*",
        metavar="NODE",
        help="only these nodes, globs allowed: 'fleet/*', 's1/*' (default: all)",
    )
    p.add_argument("--host", default="127.0.0.1", help="the address to listen on (default %(default)s)")
    p.add_argument(
        "--port",
        type=int,
        default=8765,
        metavar="N",
        help="the port to listen on (default %(default)s; 0: a free one)",
    )
    p.add_argument(
        "--token-file",
        metavar="FILE",
        help="the token a client gives as ?token= in the URL (one word, 16+ characters), or one line "
        "NAME TOKEN per operator (sets with that token are recorded as NAME); required on a "
        "non-loopback --host, where every connection needs it; on loopback, sets need it",
    )


def run(args: argparse.Namespace) -> int:
    from ...exits import UsageError
    from .._extras import require_extra
    from .._values import node_glob_arg

    require_extra("'paramdds foxglove'", "foxglove", ("websockets",))  # the server needs no mcap
    if not 0 <= args.port <= 65535:
        raise UsageError(f"--port must be within [0, 65535], got {args.port}")
    args.nodes = [node_glob_arg(n) for n in args.nodes]
    from ...foxglove.serve import run as run_foxglove

    return run_foxglove(args)
