"""The ``paramdds`` command: one entry point, a verb per task (see ``paramdds --help``).

Start-up time matters (``paramdds get`` should answer in a few hundred ms), so
this package imports only argparse and the error tree up front; a verb's module,
Cyclone and the DDS layer are imported when the verb runs, and ``--help`` never
imports Cyclone.

Every verb is a function ``(args) -> int``; errors end up in :func:`main`, which
maps them to the exit codes of :mod:`paramdds.cli._errors` and prints them as one
line on stderr (with a traceback only under ``--log-level debug``).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import signal
import sys
from collections.abc import Callable, Sequence
from types import FrameType

from ._errors import Exit, Refused, Terminated, UsageError, exit_code, is_dds_failure, one_line
from ._parser import build_parser, find_verb, resolve_globals

__all__ = ["Exit", "main"]

log = logging.getLogger("paramdds.cli")

Verb = Callable[[argparse.Namespace], int]

# verb -> "module:function", imported only when the verb runs
_IMPLEMENTATIONS = {
    "server": "paramdds.cli._serve:run_server",
    "client": "paramdds.cli._demo:run_client",
    "nodes": "paramdds.cli._requests:run_nodes",
    "list": "paramdds.cli._requests:run_list",
    "get": "paramdds.cli._requests:run_get",
    "describe": "paramdds.cli._requests:run_describe",
    "set": "paramdds.cli._requests:run_set",
    "delete": "paramdds.cli._requests:run_delete",
    "dump": "paramdds.cli._requests:run_dump",
    "load": "paramdds.cli._requests:run_load",
    "watch": "paramdds.cli._live:run_watch",
    "assign": "paramdds.cli._live:run_assign",
    "web": "paramdds.cli._web:run_web",
    "keystore": "paramdds.secure.cli:run_keystore",
    "ros2": "paramdds.cli._ros2:run_ros2",
    "zenoh": "paramdds.cli.verbs.zenoh:run",
}


def _implementation(args: argparse.Namespace) -> Verb:
    func = getattr(args, "func", None)
    if callable(func):
        return func  # type: ignore[no-any-return]
    module, _, name = _IMPLEMENTATIONS[args.verb].partition(":")
    verb: Verb = getattr(importlib.import_module(module), name)
    return verb


def _setup_logging(level: str) -> None:
    logging.basicConfig(
        level=getattr(logging, level.upper(), logging.WARNING),
        stream=sys.stderr,
        format="paramdds: %(levelname)s: %(name)s: %(message)s",
    )


def _on_sigterm(_signum: int, _frame: FrameType | None) -> None:
    raise Terminated()


def _error(message: str) -> None:
    sys.stderr.write(f"paramdds: error: {one_line(message)}\n")
    sys.stderr.flush()


def _parse(argv: list[str]) -> argparse.Namespace:
    parser = build_parser(with_bench=find_verb(argv) == "bench")
    args = parser.parse_args(argv)
    resolve_globals(args)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command; returns the exit code (the console script exits with it)."""
    arglist = list(sys.argv[1:] if argv is None else argv)
    try:
        args = _parse(arglist)
    except UsageError as exc:
        _error(str(exc))
        return Exit.USAGE
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else Exit.OK
    _setup_logging(args.log_level)
    debug = args.log_level == "debug"
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        return int(_implementation(args)(args))
    except (KeyboardInterrupt, Terminated) as exc:
        return exit_code(exc)
    except Refused:
        return Exit.REFUSED
    except BrokenPipeError:
        _quiet_stdout()
        return Exit.OK
    except Exception as exc:  # the one boundary where every error becomes an exit code
        code = exit_code(exc)
        if debug:
            log.debug("the %s verb failed", args.verb, exc_info=exc)
        message = str(exc) or type(exc).__name__
        if is_dds_failure(exc):
            message = f"DDS failed in this process: {message}"
        elif not _is_ours(exc):
            message = f"internal error: {type(exc).__name__}: {message} (--log-level debug shows more)"
        _error(message)
        return code
    finally:
        signal.signal(signal.SIGTERM, previous)


def _is_ours(exc: BaseException) -> bool:
    from ..errors import ParamddsError

    return isinstance(exc, (ParamddsError, UsageError))


def _quiet_stdout() -> None:
    """After a broken pipe, point stdout at /dev/null so the exit flush cannot fail."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except OSError:
        pass


def console() -> None:
    """``python -m paramdds.cli``."""
    raise SystemExit(main())
