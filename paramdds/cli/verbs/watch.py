"""``paramdds watch``: the current state, then every change, until Ctrl-C.

The state is printed as ``added`` events, then a ``synced`` line once discovery has
settled (or ``not synced`` when it did not within ``--timeout``), then every change
and node presence event, one line each (a JSON object each with ``-o json``): the
monitor's rules (:mod:`paramdds.dds.monitor`) make a stall, an offline/online or a
restart print only what changed, plus one ``restarted`` line for a new incarnation.
Over Zenoh, each known site that did not answer by then is one line on stderr.

``--since REV`` (one node): the node's changes after revision REV, read from its
history, instead of its state, then ``synced``, then every change live, each with who
made it and through what, in revision order, none missed or repeated
(:mod:`paramdds.dds.replay`); revisions that history no longer holds are one ``gap``
line. A node that keeps no history is one line, exit 1; a REV above the node's
revision (revisions start again when its server restarts) is exit 2.
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
    p.add_argument(
        "--since",
        metavar="REV",
        type=revision,
        help="one node: its changes after revision REV from its history, then live ones",
    )


def revision(text: str) -> int:
    """A revision for ``--since`` (argparse makes a ValueError exit 2 with the option named)."""
    if not text.strip().isascii() or not text.strip().isdigit():
        raise ValueError(text)
    return int(text)


def run(args: argparse.Namespace) -> int:
    import time

    from ...exits import Exit
    from ...session import Session
    from .._events import EventPrinter
    from .._live import wait_until_interrupted
    from .._values import node_glob_arg

    if args.since is not None:
        return run_since(args)
    nodes = [node_glob_arg(n) for n in args.nodes]
    printer = EventPrinter(args.output, args.prefixes)
    with Session(args) as session:
        started = time.monotonic()
        monitor = session.monitor(nodes or None, on_event=printer)
        settled = monitor.settle(args.timeout, started=started)
        printer.synced(settled, time.monotonic() - started)
        missing = session.missing_sites()
        if missing:
            from ...zenoh.completeness import lacking_line
            from .._output import problem

            for site, lack in missing.items():
                problem(lacking_line(site, lack))
        wait_until_interrupted(printer.broken)
    return Exit.OK


def run_since(args: argparse.Namespace) -> int:
    """``watch NODE --since REV``: the node's history after REV, ``synced``, then live changes."""
    import time

    from ...core.monitor_events import MonitorEvent
    from ...core.replay import Gap
    from ...dds.replay import ReplayWatch
    from ...exits import Exit, UsageError
    from ...session import Session
    from .._events import EventPrinter
    from .._live import wait_until_interrupted
    from .._output import problem
    from .._values import node_arg

    if len(args.nodes) != 1 or any(c in args.nodes[0] for c in "*?["):
        raise UsageError("watch --since REV follows one node: give exactly one node, not a glob")
    node = node_arg(args.nodes[0])
    printer = EventPrinter(args.output, args.prefixes, changes=False)
    with Session(args) as session:
        watch = ReplayWatch(
            session.client(), node, args.since, lambda item: (
                printer.gap(node, item) if isinstance(item, Gap) else printer.record(item)
            ),
        )  # fmt: skip

        def on_event(event: MonitorEvent) -> None:
            watch.on_event(event)
            printer(event)

        started = time.monotonic()
        monitor = session.monitor([node], on_event=on_event)
        monitor.settle(args.timeout, started=started)
        state = monitor.snapshot().get(node)
        if state is not None and state.online and args.since > state.revision:
            raise UsageError(
                f"--since {args.since}: node {node!r} is at revision {state.revision} "
                "(revisions start again when its server restarts)"
            )
        try:
            reply = watch.replay()
            if reply.compacted:
                problem(
                    f"the history of node {node!r} after revision {args.since} was partly dropped by "
                    "retention: the gap line says which revisions are lost"
                )
            printer.synced(True, time.monotonic() - started)
            wait_until_interrupted(printer.broken)
        finally:
            watch.close()
    return Exit.OK
