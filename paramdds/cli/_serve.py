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
import sys

from ._errors import Exit, UsageError
from ._live import wait_until_interrupted
from ._parser import DEFAULT_NODE
from ._requests import node_arg
from ._session import Session


def run_server(args: argparse.Namespace) -> int:
    from ..runtime import ServerOptions, ServerProcess, prepare

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
    process = ServerProcess(tables, store, lambda: session.participant, session.qos)
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

    try:
        importlib.import_module(module)
    except Exception as exc:  # any failure of a user's module is bad local input
        raise UsageError(f"--validators {module}: cannot import it: {type(exc).__name__}: {exc}") from exc
