"""``paramdds watch``: the current state, then every change, until Ctrl-C.

The state is printed as ``added`` events, then a ``synced`` line once discovery has
settled (or ``not synced`` when it did not within ``--timeout``), then every change
and node presence event, one line each (a JSON object each with ``-o json``): the
monitor's rules (:mod:`paramdds.dds.monitor`) make a stall, an offline/online or a
restart print only what changed, plus one ``restarted`` line for a new incarnation.
Over Zenoh, each known site that did not answer by then is one line on stderr.
"""

from __future__ import annotations

import argparse

HELP = "current state, then every change, until Ctrl-C"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "nodes",
        nargs="*",
        metavar="NODE",
        help="only these nodes, globs allowed: 'fleet/*', 's1/*' (default: all)",
    )
    p.add_argument("--prefix", action="append", dest="prefixes", default=[], metavar="P")


def run(args: argparse.Namespace) -> int:
    import time

    from ...exits import Exit
    from ...session import Session
    from .._events import EventPrinter
    from .._live import settle, wait_until_interrupted
    from .._values import node_glob_arg

    nodes = [node_glob_arg(n) for n in args.nodes]
    printer = EventPrinter(args.output, args.prefixes)
    with Session(args) as session:
        started = time.monotonic()
        monitor = session.monitor(nodes or None, on_event=printer)
        settled = settle(monitor, started, args.timeout, lambda: printer.last_event)
        printer.synced(settled, time.monotonic() - started)
        missing = session.missing_sites()
        if missing:
            from ...zenoh.completeness import lacking_line
            from .._output import problem

            for site, lack in missing.items():
                problem(lacking_line(site, lack))
        wait_until_interrupted(printer.broken)
    return Exit.OK
