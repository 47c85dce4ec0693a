"""``paramdds web``: the console lives in :mod:`paramdds.web`; this verb checks the extra and runs it."""

from __future__ import annotations

import argparse

HELP = "a live browser console for every node's parameters (needs the web extra)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--bind", default="127.0.0.1:8800", metavar="HOST:PORT", help="where to listen (default %(default)s)"
    )
    p.add_argument(
        "--port", type=int, metavar="N", help="the port to listen on, on the host of --bind (0: a free one)"
    )
    p.add_argument("--read-only", action="store_true", help="serve no write endpoint")
    p.add_argument(
        "--token-file",
        metavar="FILE",
        help="the bearer token required for writes (one word, 16+ characters), or one line "
        "NAME TOKEN per operator (writes with that token are recorded as NAME); "
        "required on a non-loopback --bind, where reads need it too",
    )
    p.add_argument(
        "--allow-host",
        action="append",
        metavar="NAME",
        help="another name the console is reached under (checked against the Host header: "
        "a DNS alias or a proxy's name; the bind address is always allowed); repeatable",
    )
    p.add_argument(
        "--schema",
        action="append",
        metavar="NODE=FILE",
        help="check writes to NODE against the JSON Schema FILE before sending them (the node checks too)",
    )


def run(args: argparse.Namespace) -> int:
    from .._extras import require_extra

    require_extra("'paramdds web'", "web")
    if args.port is not None:
        host = args.bind.rpartition(":")[0] or "127.0.0.1"
        args.bind = f"{host}:{args.port}"
    from ...web.serve import run_web

    return run_web(args)
