"""``paramdds demo`` (also ``paramdds client``): list, get and set on a target, printing its events.

1. wait (bounded) until the target is present; exit 3 naming it if it never is;
2. print the events of the target as they arrive, grouped per revision::

       [PARAM_EVENT] From node: robot1
         NEW: robot.max_velocity

3. ``=== LIST PARAMETERS ===``, ``=== GET PARAMETERS ===`` and, with a params
   file, ``=== SET PARAMETERS ===`` setting the parameters of the file on the
   target in file order, each shown with its value and outcome (``SUCCESS``,
   ``UNCHANGED`` for a value the node already holds, which is not sent, or
   ``FAILED`` with the node's reason), then the events the set caused (``CHANGED``),
   then ``=== A REFUSED SET ===``: a value of the wrong type for a parameter of a
   fixed type, which the node refuses with its reason (nothing changes);
4. keep printing events until Ctrl-C (exit 130), or with ``--once`` exit then
   (exit 0, or 1 if a set failed).

``run.sh`` gives it ``examples/demo_set.yaml``, whose values partly differ from the
``examples/params.yaml`` its server loads, so that the demo shows writes succeed.
"""

from __future__ import annotations

import argparse
import sys
import threading
from typing import TYPE_CHECKING

from .._parser import DEFAULT_NODE

if TYPE_CHECKING:
    from ...core.values import Parameter
    from ...dds.client import ParameterClient
    from ...dds.monitor import MonitorEvent

HELP = "the demo client: list, get and set on a target, printing events (alias: client)"

SETTLE = 2.0  # seconds --once waits at most for the events of its own set


class DemoPrinter:
    """Prints events and demo sections without interleaving them line by line."""

    LABELS = {"added": "NEW", "modified": "CHANGED", "deleted": "DELETED"}

    def __init__(self) -> None:
        self.lock = threading.RLock()
        self._printed = threading.Condition(self.lock)
        self._group: tuple[str, int] | None = None
        self._synced = False
        self._revisions: dict[str, int] = {}  # the newest revision printed, per node

    def event(self, e: MonitorEvent) -> None:
        kind = e.event.value
        if kind in ("site_offline", "site_online", "site_status"):  # a site's: no node nor parameter
            return
        with self.lock:
            if kind == "synced":
                self._synced = True
                return
            if kind in ("online", "offline"):
                if self._synced:
                    self._lines(f"[NODE] {e.node} is {kind}")
                    self._group = None
                return
            if self._group != (e.node, e.revision):
                self._group = (e.node, e.revision)
                self._lines(f"[PARAM_EVENT] From node: {e.node}")
            self._lines(f"  {self.LABELS.get(kind, kind.upper())}: {e.name}")
            self._revisions[e.node] = max(e.revision, self._revisions.get(e.node, 0))
            self._printed.notify_all()

    def wait_printed(self, node: str, revision: int, timeout: float) -> bool:
        """Wait until the events of ``node`` up to ``revision`` have been printed."""
        with self._printed:
            return self._printed.wait_for(lambda: self._revisions.get(node, 0) >= revision, timeout)

    def section(self, *lines: str) -> None:
        with self.lock:
            self._group = None
            self._lines("", *lines)

    @staticmethod
    def _lines(*lines: str) -> None:
        sys.stdout.write("".join(line + "\n" for line in lines))
        sys.stdout.flush()


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "-t",
        "--target",
        default=DEFAULT_NODE,
        metavar="NAME",
        help=f"the node to talk to (default {DEFAULT_NODE})",
    )
    p.add_argument("-p", "--params-file", metavar="FILE", help="parameters to set on the target, in order")
    p.add_argument("--once", action="store_true", help="exit after the demo instead of watching")
    p.add_argument(
        "--wait",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="how long to wait for the target to appear (default 10)",
    )


def run(args: argparse.Namespace) -> int:
    from ...exits import Exit
    from ...formats.files import read_values
    from ...session import Session
    from .._live import wait_until_interrupted
    from .._values import node_arg

    target = node_arg(args.target)
    params = read_values(args.params_file, target) if args.params_file else []
    printer = DemoPrinter()
    with Session(args, app_name="paramdds-client") as session:
        client = session.client()
        monitor = session.monitor([target], on_event=printer.event)
        client.wait_for_node(target, timeout=args.wait)
        monitor.wait_complete([target], timeout=args.timeout)
        ok = _demo(client, printer, target, params, args.timeout)
        if args.once:
            return Exit.OK if ok else Exit.REFUSED
        wait_until_interrupted()
    return Exit.OK


def _demo(
    client: ParameterClient,
    printer: DemoPrinter,
    target: str,
    params: list[Parameter],
    timeout: float,
) -> bool:
    """The LIST, GET and SET sections; True when every set succeeded."""
    from .._output import typed

    names = sorted(client.list(target).names)
    printer.section(
        "=== LIST PARAMETERS ===",
        f"[LIST] Found {len(names)} parameters on {target}:",
        *(f"  - {n}" for n in names),
    )
    reply = client.get(target, names)
    found = [r for r in reply.results if r.value is not None]
    printer.section(
        "=== GET PARAMETERS ===",
        f"[GET] Retrieved {len(found)} parameters:",
        *(f"  {r.name} = {typed(r.value)}" for r in found),
    )
    if not params:
        printer.section("=== SET PARAMETERS ===", "[SET] nothing to set (no --params-file)")
        return True
    from ...file_load import UNCHANGED, load

    values = {p.name: p.value for p in params}
    with printer.lock:  # the events of this set print after its section
        result = load(client, target, params)
        lines = [f"[SET] Response from: {result.node}"]
        for i, r in enumerate(result.results):
            shown = f"{r.name} = {typed(values.get(r.name))}"
            if not r.successful:
                lines.append(f"  Result[{i}]: {shown}: FAILED: {r.reason}")
            else:
                lines.append(f"  Result[{i}]: {shown}: {'UNCHANGED' if r.reason == UNCHANGED else 'SUCCESS'}")
        printer.section("=== SET PARAMETERS ===", *lines)
    if any(r.successful and r.reason != UNCHANGED for r in result.results):
        # the events the set caused (they carry its revision), before the next section
        printer.wait_printed(target, result.revision, min(timeout, SETTLE))
    _refusal(client, printer, target)
    return result.successful


def _refusal(client: ParameterClient, printer: DemoPrinter, target: str) -> None:
    """Show a refusal: a string for the first parameter of a fixed, non-string type."""
    from ...core.values import Parameter, ParameterType, ParameterValue
    from .._output import typed

    names = sorted(client.list(target).names)
    described = client.get(target, names, with_descriptors=True).results
    fixed = [
        r.name
        for r in described
        if r.value is not None
        and r.descriptor is not None
        and not r.descriptor.dynamic_typing
        and not r.descriptor.read_only
        and r.value.type not in (ParameterType.STRING, ParameterType.NOT_SET)
    ]
    if not fixed:
        return
    wrong = Parameter(fixed[0], ParameterValue.of(ParameterType.STRING, "fast"))
    (r,) = client.set(target, [wrong]).results
    outcome = "SUCCESS" if r.successful else f"FAILED: {r.reason}"
    printer.section(
        "=== A REFUSED SET ===", f"[SET] {wrong.name} = {typed(wrong.value)}", f"  Result[0]: {outcome}"
    )
