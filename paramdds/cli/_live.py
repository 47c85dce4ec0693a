"""The verbs that stay up until Ctrl-C: watch and assign."""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from ..core.values import Parameter
from ._errors import Exit, UsageError
from ._output import dumps_json, json_value, typed
from ._requests import node_arg
from ._session import Session
from ._values import parse_assignments

if TYPE_CHECKING:
    from ..dds.monitor import MonitorEvent, ParameterMonitor

SETTLE = 0.5  # seconds a fresh watcher gives discovery before it calls the state complete
QUIET = 0.1  # seconds without events before the state counts as received


def wait_until_interrupted(broken: threading.Event | None = None) -> None:
    """Block the main thread until Ctrl-C (KeyboardInterrupt) or SIGTERM (Terminated)."""
    while True:
        if broken is not None and broken.wait(1.0):
            raise BrokenPipeError("stdout was closed")
        if broken is None:
            time.sleep(3600)


def matches_prefix(name: str, prefixes: Sequence[str]) -> bool:
    """ROS list semantics: ``robot`` matches ``robot`` and ``robot.x``, not ``robotic``."""
    if not prefixes:
        return True
    for p in prefixes:
        p = p.rstrip(".")
        if not p or name == p or name.startswith(p + "."):
            return True
    return False


class EventPrinter:
    """Prints monitor events as ``watch`` does: JSON lines or one readable line each.

    Called on the monitor's threads; one lock keeps lines whole. Node presence events
    are printed only after ``synced`` (before it, the ``added`` events are the state).
    """

    def __init__(self, output: str, prefixes: Sequence[str]) -> None:
        self._json = output == "json"
        self._prefixes = list(prefixes)
        self._lock = threading.Lock()
        self._synced = False
        self.broken = threading.Event()
        self.last_event = time.monotonic()

    def __call__(self, event: MonitorEvent) -> None:
        from ..dds.monitor import EventKind

        self.last_event = time.monotonic()
        if event.event is EventKind.SYNCED:
            return  # printed by :meth:`synced`, once the state has settled (see settle())
        if event.event in (EventKind.ONLINE, EventKind.OFFLINE):
            if self._synced:
                self._write(self._node_line(event))
            return
        if matches_prefix(event.name, self._prefixes):
            self._write(self._parameter_line(event))

    def synced(self, settled: bool = True, waited: float = 0.0) -> None:
        """Print the ``synced`` line: the current state has been printed. When discovery
        did not settle within the timeout, say so (``not_synced``) instead."""
        with self._lock:
            self._synced = True
        if settled:
            self._write('{"event": "synced"}' if self._json else "synced")
        elif self._json:
            self._write(dumps_json({"event": "not_synced", "waited": round(waited, 3)}, pretty=False))
        else:
            self._write(f"not synced: the state did not settle within {waited:g} s; it may be incomplete")

    def _node_line(self, e: MonitorEvent) -> str:
        if self._json:
            return dumps_json(
                {
                    "event": e.event.value,
                    "node": e.node,
                    "name": None,
                    "type": None,
                    "value": None,
                    "revision": e.revision,
                    "stamp": e.stamp,
                },
                pretty=False,
            )
        return f"{e.event.value:<8} {e.node}"

    def _parameter_line(self, e: MonitorEvent) -> str:
        from ..dds.monitor import EventKind

        value = None if e.event is EventKind.DELETED else e.value
        if self._json:
            return dumps_json(
                {
                    "event": e.event.value,
                    "node": e.node,
                    "name": e.name,
                    "type": value.type.label if value is not None else "not_set",
                    "value": json_value(value),
                    "revision": e.revision,
                    "stamp": e.stamp,
                },
                pretty=False,
            )
        shown = "" if value is None else f" = {typed(value)}"
        return f"{e.event.value:<8} {e.node} {e.name}{shown}  (rev {e.revision})"

    def _write(self, line: str) -> None:
        with self._lock:
            try:
                sys.stdout.write(line + "\n")
                sys.stdout.flush()
            except OSError:
                self.broken.set()


def settle(monitor: ParameterMonitor, started: float, limit: float, quiet: Callable[[], float]) -> bool:
    """Wait (at most ``limit`` s from ``started``) until the monitor holds the current state.

    A fresh process cannot know when discovery is over, so besides the monitor's own
    sync it waits for at least :data:`SETTLE` seconds since start, then for every online
    node to be complete and :data:`QUIET` seconds without events (``quiet()`` returns
    the time of the last one). False when the limit was reached first.
    """
    deadline = started + limit
    monitor.wait_synced(limit)
    pause = started + SETTLE - time.monotonic()
    if pause > 0:
        time.sleep(pause)
    while True:
        remaining = deadline - time.monotonic()
        done = monitor.wait_until(
            lambda s: all(st.complete or not st.online for st in s.values()), max(0.0, remaining)
        )
        wait = quiet() + QUIET - time.monotonic()
        if wait <= 0 or remaining <= 0:
            return done and remaining > 0
        time.sleep(wait)


def run_watch(args: argparse.Namespace) -> int:
    nodes = [node_arg(n) for n in args.nodes]
    printer = EventPrinter(args.output, args.prefixes)
    with Session(args) as session:
        started = time.monotonic()
        monitor = session.monitor(nodes or None, on_event=printer)
        settled = settle(monitor, started, args.timeout, lambda: printer.last_event)
        printer.synced(settled, time.monotonic() - started)
        wait_until_interrupted(printer.broken)
    return Exit.OK


def run_assign(args: argparse.Namespace) -> int:
    from ..runtime import read_values

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
