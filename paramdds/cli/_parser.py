"""The argument parser of the ``paramdds`` command (no heavy imports here).

Global options are accepted before or after the verb: the top-level parser
defines them with real defaults and every verb's parser repeats them with
``SUPPRESS`` defaults, so a value given after the verb overrides one given
before it and an absent one leaves the top-level value alone. Environment
defaults (``PARAMDDS_DOMAIN``, ``PARAMDDS_LOCALHOST``) are applied by
:func:`resolve_globals` once parsing is done. Each verb adds its own arguments
(:mod:`paramdds.cli.verbs`).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import NoReturn

from ..exits import UsageError

OUTPUTS = ("table", "yaml", "json")
LOG_LEVELS = ("debug", "info", "warning", "error", "critical")
DEFAULT_DOMAIN = 1
DEFAULT_TIMEOUT = 5.0
DEFAULT_NODE = "parameter_server"


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line on stderr and exit code 2."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see '{self.prog} --help')")

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        if message:
            sys.stderr.write(message)
        raise SystemExit(status)


def _add_globals(p: argparse.ArgumentParser, *, top: bool) -> None:
    """The global options; on verb parsers (``top=False``) they default to SUPPRESS."""

    def default(value: object) -> object:
        return value if top else argparse.SUPPRESS

    g = p.add_argument_group("global options (before or after the verb)")
    g.add_argument(
        "-d",
        "--domain",
        type=int,
        metavar="ID",
        default=default(None),
        help=f"DDS domain id (default {DEFAULT_DOMAIN}, env PARAMDDS_DOMAIN)",
    )
    g.add_argument(
        "-q",
        "--qos-file",
        metavar="FILE",
        default=default(None),
        help="QoS profiles XML (default: the packaged qos/DDS_QOS_PROFILES.xml)",
    )
    g.add_argument(
        "-o", "--output", choices=OUTPUTS, default=default("table"), help="output format (default table)"
    )
    g.add_argument(
        "--timeout",
        type=float,
        metavar="SECONDS",
        default=default(DEFAULT_TIMEOUT),
        help=f"how long to wait for an answer (default {DEFAULT_TIMEOUT:g})",
    )
    g.add_argument(
        "--as",
        dest="as_name",
        metavar="NAME",
        default=default(None),
        help="the identity your writes are recorded under (default $PARAMDDS_AS, else USER@host); "
        "a claim, which secure mode replaces with your certificate's subject",
    )
    g.add_argument(
        "--log-level",
        choices=LOG_LEVELS,
        type=str.lower,
        default=default("warning"),
        help="diagnostics on stderr (debug also prints tracebacks)",
    )
    g.add_argument(
        "--localhost",
        action="store_true",
        default=default(False),
        help="loopback only, no multicast (env PARAMDDS_LOCALHOST=1)",
    )
    g.add_argument(
        "--identity",
        metavar="DIR",
        default=default(None),
        help="secure mode: an identity made by 'paramdds keystore add' (env PARAMDDS_IDENTITY)",
    )
    g.add_argument(
        "--zenoh",
        metavar="ENDPOINT",
        default=default(None),
        help="reach every site's nodes (SITE/NODE) through a Zenoh router, not DDS (env PARAMDDS_ZENOH)",
    )


class _Version(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata
    costs every other command about 10 ms and the email package)."""

    def __call__(self, parser: argparse.ArgumentParser, *_args: object, **_kwargs: object) -> None:
        sys.stdout.write(f"paramdds {_version()}\n")
        parser.exit()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("paramdds")
    except PackageNotFoundError:  # run from a checkout that is not installed
        return "unknown"


def build_parser(argv: Sequence[str] | None = None) -> Parser:
    """The parser: the global options, then every verb of :data:`~paramdds.cli.verbs.VERBS`.

    Given the command's arguments, only the verb they name is built whole (its module
    imported, its arguments and the global options added); the others are names only.
    Building all of them costs every run 5-10 ms, and a run parses one verb. A top-level
    ``--help``, or arguments that name no verb, get every verb built.
    """
    from .verbs import ALIASES, CANONICAL, VERBS, verb

    chosen = None if argv is None else _named_verb(argv, [*VERBS, *CANONICAL])
    chosen = CANONICAL.get(chosen, chosen) if chosen else None
    top = Parser(
        prog="paramdds",
        description="ROS 2 parameters over seven keyed DDS topics (Cyclone DDS).",
        epilog="Exit codes: 0 ok, 1 refused by the node (or lacking: a name, its history; diff: the sides "
        "differ), 2 usage or bad input, "
        "3 node absent, timeout, or a fleet answer lacking a site, "
        "4 a failure in this process (DDS, or an internal error), "
        "5 outcome unknown (a write sent and not answered: it may have been applied), 130 interrupted.",
    )
    top.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
    _add_globals(top, top=True)
    sub = top.add_subparsers(dest="verb", metavar="VERB", parser_class=Parser)
    sub.required = True
    for name in VERBS:
        if chosen is not None and name != chosen:
            sub.add_parser(name, aliases=ALIASES.get(name, ()))  # not this run's verb: its name is enough
            continue
        module = verb(name)
        # a verb may give a global option another meaning (record's -o is its file): OVERRIDES_GLOBALS
        conflict = "resolve" if getattr(module, "OVERRIDES_GLOBALS", False) else "error"
        p: Parser = sub.add_parser(
            name, aliases=ALIASES.get(name, ()), help=module.HELP, description=module.HELP,
            conflict_handler=conflict,
        )
        _add_globals(p, top=False)
        module.add_arguments(p)
    return top


def _named_verb(argv: Sequence[str], verbs: Sequence[str]) -> str | None:
    """The verb ``argv`` names: the first argument that is a verb once the global options
    before it and their values are set aside (``-o json get``); None when there is none, or
    when a top-level ``--help`` comes first (it lists every verb with its help)."""
    probe = Parser(prog="paramdds", add_help=False)
    _add_globals(probe, top=True)
    try:
        _, rest = probe.parse_known_args(list(argv))
    except UsageError:  # the whole parser reports it
        return None
    for arg in rest:
        if arg in ("-h", "--help"):
            return None
        if arg in verbs:
            return arg
    return None


def resolve_globals(args: argparse.Namespace, environ: dict[str, str] | None = None) -> None:
    """Fill in environment defaults and check the global values."""
    env = os.environ if environ is None else environ
    if args.domain is None:
        text = env.get("PARAMDDS_DOMAIN", "").strip()
        try:
            args.domain = int(text) if text else DEFAULT_DOMAIN
        except ValueError:
            raise UsageError(f"PARAMDDS_DOMAIN must be an integer, got {text!r}") from None
    if not 0 <= args.domain <= 232:
        raise UsageError(f"the domain id must be between 0 and 232, got {args.domain}")
    if not args.localhost:
        args.localhost = env.get("PARAMDDS_LOCALHOST", "").strip().lower() in ("1", "true", "yes", "on")
    if not args.identity:
        args.identity = env.get("PARAMDDS_IDENTITY", "").strip() or None
    if not args.zenoh:
        args.zenoh = env.get("PARAMDDS_ZENOH", "").strip() or None
    if args.zenoh:
        from ..zenoh.config import check_endpoint  # no Zenoh import: the shape only

        args.zenoh = check_endpoint(args.zenoh, error=UsageError)
    if args.timeout is None or not args.timeout > 0:
        raise UsageError(f"--timeout must be a positive number of seconds, got {args.timeout}")
