"""``paramdds server``: host nodes until Ctrl-C (exit 130) or SIGTERM (exit 0).

Everything local is read and checked before DDS starts: a bad parameter file,
spec or persistence file ends the command with exit 2 and one line naming the
file, and nothing is published.

Stopping: Ctrl-C (SIGINT) ends with exit 130, SIGTERM with exit 0; both close
the server gracefully (its nodes go offline, their last values stay with the
monitors). A shell without job control starts background jobs with SIGINT
ignored, and Python keeps it ignored: stop such a server with SIGTERM (run.sh
--demo does).
"""

from __future__ import annotations

import argparse

from .._argtypes import positive_float, positive_int
from .._parser import DEFAULT_NODE

# core.history's Retention defaults (tests/cli/test_cli_local.py checks they agree): written
# here so that --help imports no more than the verbs
HISTORY_RECORDS = 10_000
HISTORY_DAYS = 30.0

HELP = "host one or more nodes and serve their parameters"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "-n",
        "--node-name",
        action="append",
        dest="node_names",
        metavar="NAME",
        help=f"a node to host; repeat for several (default {DEFAULT_NODE})",
    )
    p.add_argument(
        "-p",
        "--params-file",
        action="append",
        dest="params_files",
        default=[],
        metavar="FILE",
        help="parameter file (seed or ROS 2 format); repeat, later wins",
    )
    p.add_argument("--spec", metavar="FILE", help="generate_parameter_library spec declaring the parameters")
    p.add_argument(
        "--schema",
        metavar="FILE",
        help="JSON Schema (Autoware's FILE.schema.json) declaring the parameters and checking every change",
    )
    p.add_argument(
        "--lenient",
        action="store_true",
        help="--schema: warn on unknown keywords; start without file values the schema refuses",
    )
    p.add_argument(
        "--validators",
        action="append",
        default=[],
        metavar="MODULE",
        help="import MODULE (a Python module name) that registers custom spec validators; repeat for several",
    )
    p.add_argument(
        "--strict-spec",
        action="store_true",
        help="refuse a spec naming a custom validator nobody registered (default: warn, not enforced)",
    )
    p.add_argument(
        "--persist",
        metavar="FILE",
        help="keep runtime changes in FILE (created if missing, reloaded at start)",
    )
    p.add_argument(
        "--history-records",
        type=positive_int,
        metavar="N",
        default=HISTORY_RECORDS,
        help=f"history kept per node: the newest N records (default {HISTORY_RECORDS:,})",
    )
    p.add_argument(
        "--history-days",
        type=positive_float,
        metavar="D",
        default=HISTORY_DAYS,
        help=f"history kept per node: none older than D days (default {HISTORY_DAYS:g})",
    )
    p.add_argument("--allow-undeclared", action="store_true", help="accept sets of undeclared names")
    p.add_argument("--strict-types", action="store_true", help="never widen an integer to a double")
    p.add_argument("--read-only", action="store_true", help="serve reads, refuse every set and delete")
    p.add_argument("--use-sim-time", action="store_true", help="declare use_sim_time (bool, false)")


def run(args: argparse.Namespace) -> int:
    import sys

    from ...core.history import Retention
    from ...exits import Exit, UsageError
    from ...server_process import ServerOptions, ServerProcess, prepare
    from ...session import Session
    from .._live import wait_until_interrupted
    from .._values import node_arg

    for module in args.validators:
        import_validators(module)
    if args.spec and args.schema:
        raise UsageError("--spec and --schema both declare the parameters: give one")
    names = [node_arg(n) for n in (args.node_names or [DEFAULT_NODE])]
    options = ServerOptions(
        node_names=list(dict.fromkeys(names)),
        params_files=list(args.params_files),
        spec=args.spec,
        strict_spec=args.strict_spec,
        schema=args.schema,
        lenient=args.lenient,
        persist=args.persist,
        allow_undeclared=args.allow_undeclared,
        strict_types=args.strict_types,
        read_only=args.read_only,
        use_sim_time=args.use_sim_time,
    )
    tables, lines, store = prepare(options)
    session = Session(args, app_name="paramdds-server")
    retention = Retention(args.history_records, args.history_days * 86400)
    process = ServerProcess(tables, store, lambda: session.participant, session.qos, retention=retention)
    try:
        process.start()
        for line in lines:
            sys.stdout.write(line + "\n")
        for node, table in tables.items():
            sys.stdout.write(
                f"[SERVER] Serving node {node} with {len(table)} parameters on domain {args.domain}\n"
            )
        sys.stdout.flush()
        wait_until_interrupted()
    finally:
        process.close()
        session.close()
    return Exit.OK


def import_validators(module: str) -> None:
    """Import ``module``, which registers custom spec validators (``--validators``); exit 2 if it fails."""
    import importlib

    from ...exits import UsageError

    try:
        importlib.import_module(module)
    except Exception as exc:  # any failure of a user's module is bad local input
        raise UsageError(f"--validators {module}: cannot import it: {type(exc).__name__}: {exc}") from exc
