"""The ``paramdds`` command: one entry point, a verb per task (see ``paramdds --help``).

Start-up time matters (``paramdds get`` should answer in a few hundred ms), so
this package imports only argparse and the exit codes up front; building the
parser imports every verb's module (:mod:`paramdds.cli.verbs`, argparse only at
their top), and a verb imports Cyclone and the DDS layer when it runs, so
``--help`` never imports Cyclone.

Every verb is a module of :mod:`paramdds.cli.verbs` whose ``run(args) -> int``
returns the exit code; errors end up in :func:`main`, which maps them to the exit
codes of :mod:`paramdds.exits` and prints them as one line on stderr (with
a traceback only under ``--log-level debug``).
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
from collections.abc import Sequence
from types import FrameType

from ..exits import Exit, Refused, Terminated, UsageError, exit_code, is_dds_failure, one_line
from ._parser import build_parser, resolve_globals
from .verbs import verb

__all__ = ["Exit", "main"]

log = logging.getLogger("paramdds.cli")


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
    args = build_parser(argv).parse_args(argv)
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
        return int(verb(args.verb).run(args))
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
