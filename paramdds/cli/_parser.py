"""The argument parser of the ``paramdds`` command (no heavy imports here).

Global options are accepted before or after the verb: the top-level parser
defines them with real defaults and every verb's parser repeats them with
``SUPPRESS`` defaults, so a value given after the verb overrides one given
before it and an absent one leaves the top-level value alone. Environment
defaults (``PARAMDDS_DOMAIN``, ``PARAMDDS_LOCALHOST``) are applied by
:func:`resolve_globals` once parsing is done.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import NoReturn

from ._errors import UsageError

VERBS = (
    "server",
    "client",
    "nodes",
    "list",
    "get",
    "describe",
    "set",
    "delete",
    "dump",
    "load",
    "watch",
    "assign",
    "web",
    "keystore",
    "ros2",
    "zenoh",
    "bench",
)
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


def _verb(sub: argparse._SubParsersAction[Parser], name: str, help_text: str) -> Parser:
    p: Parser = sub.add_parser(name, help=help_text, description=help_text)
    _add_globals(p, top=False)
    return p


def _server(p: Parser) -> None:
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
    p.add_argument("--allow-undeclared", action="store_true", help="accept sets of undeclared names")
    p.add_argument("--strict-types", action="store_true", help="never widen an integer to a double")
    p.add_argument("--read-only", action="store_true", help="serve reads, refuse every set and delete")
    p.add_argument("--use-sim-time", action="store_true", help="declare use_sim_time (bool, false)")


def _client(p: Parser) -> None:
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


def _keystore(p: Parser) -> None:
    actions = p.add_subparsers(dest="action", metavar="ACTION", parser_class=Parser)
    actions.required = True
    a = actions.add_parser("init", help="create the CAs and the signed governance in a new keystore")
    a.add_argument("keystore", metavar="KEYSTORE")
    a = actions.add_parser("add", help="issue an identity for a role and node-id globs")
    a.add_argument("keystore", metavar="KEYSTORE")
    a.add_argument("name", metavar="NAME")
    a.add_argument("--role", required=True, choices=("server", "operator", "viewer", "admin"))
    a.add_argument(
        "--nodes", action="append", required=True, metavar="GLOB", help="node ids granted (repeat; '*': all)"
    )
    a = actions.add_parser("install", help="build Cyclone DDS C with security and rebuild the binding on it")
    a.add_argument("--source", metavar="TARBALL|DIR", help="Cyclone DDS C 11.0.1 sources (default: upstream)")
    a.add_argument("--prefix", metavar="DIR", required=True, help="where to install the secure build")
def _ros2(p: Parser) -> None:
    p.add_argument(
        "--mirror",
        action="append",
        default=[],
        metavar="GLOB",
        help="ROS 2 nodes (/ns/name globs) to mirror on paramdds; repeat (default: every node)",
    )
    p.add_argument(
        "--exclude", action="append", default=[], metavar="GLOB", help="ROS 2 nodes never mirrored; repeat"
    )
    p.add_argument(
        "--no-mirror", action="store_true", help="mirror no ROS 2 node (only expose paramdds nodes)"
    )
    p.add_argument(
        "--expose",
        action="append",
        default=[],
        metavar="GLOB",
        help="paramdds nodes (globs) to serve to ROS 2 tools; repeat (default: none)",
    )
    p.add_argument(
        "--ros-domain",
        type=int,
        metavar="N",
        help="the ROS 2 domain (default: ROS_DOMAIN_ID, else 0); may differ from -d",
    )
    p.add_argument(
        "--ros-timeout",
        type=float,
        default=5.0,
        metavar="SECONDS",
        help="how long a forwarded call waits for a ROS 2 node (default %(default)s)",
    )
    p.add_argument(
        "--resync",
        type=float,
        default=60.0,
        metavar="SECONDS",
        help="re-read each mirrored node this often, 0 never (default %(default)s)",
    )


def _assignment_values(p: Parser) -> None:
    p.add_argument("assignments", nargs="*", metavar="NAME=VALUE", help="values typed as YAML scalars")


def build_parser(*, with_bench: bool = False) -> Parser:
    """The whole parser. ``with_bench`` imports the bench verb's own parser."""
    top = Parser(
        prog="paramdds",
        description="ROS 2 parameters over seven keyed DDS topics (Cyclone DDS).",
        epilog="Exit codes: 0 ok, 1 refused by the node, 2 usage or bad input, "
        "3 node absent or timeout, 130 interrupted.",
    )
    _add_globals(top, top=True)
    sub = top.add_subparsers(dest="verb", metavar="VERB", parser_class=Parser)
    sub.required = True

    _server(_verb(sub, "server", "host one or more nodes and serve their parameters"))
    _client(_verb(sub, "client", "the seed demo: list, get and set on a target, printing events"))
    _verb(sub, "nodes", "every node alive now: online, parameter count, host, pid, revision")

    p = _verb(sub, "list", "parameter names of a node")
    p.add_argument("node", metavar="NODE")
    p.add_argument("--prefix", action="append", dest="prefixes", default=[], metavar="P")
    p.add_argument("--depth", type=int, default=0, metavar="D", help="0: every level (default)")

    for verb, text in (
        ("get", "values of parameters"),
        ("describe", "descriptors of parameters"),
        ("delete", "delete (undeclare) parameters"),
    ):
        p = _verb(sub, verb, text)
        p.add_argument("node", metavar="NODE")
        p.add_argument("names", nargs="+", metavar="NAME")

    p = _verb(sub, "set", "set parameters (each on its own, or --atomic)")
    p.add_argument("node", metavar="NODE")
    p.add_argument("assignments", nargs="+", metavar="NAME=VALUE", help="values typed as YAML scalars")
    p.add_argument("--atomic", action="store_true", help="all or nothing")
    p.add_argument(
        "--if-revision",
        metavar="[INCARNATION:]N",
        help="apply only while the node is still at that state: INCARNATION:N (the 'at' of "
        "`paramdds nodes -o json`) also fails after a restart; a bare N compares the revision alone",
    )

    p = _verb(sub, "dump", "a node's parameters as a ROS 2 parameter file on stdout")
    p.add_argument("node", metavar="NODE")
    p.add_argument("--no-descriptors", action="store_true", help="values only")

    p = _verb(sub, "load", "set a node's parameters from a parameter file")
    p.add_argument("node", metavar="NODE")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--atomic", action="store_true", help="all or nothing")

    p = _verb(sub, "watch", "current state, then every change, until Ctrl-C")
    p.add_argument("nodes", nargs="*", metavar="NODE", help="only these nodes (default: all)")
    p.add_argument("--prefix", action="append", dest="prefixes", default=[], metavar="P")

    p = _verb(sub, "assign", "hold values for a node; they reach it whenever it starts (until Ctrl-C)")
    p.add_argument("node", metavar="NODE")
    _assignment_values(p)
    p.add_argument("--file", metavar="FILE", help="a parameter file with more values (command line wins)")

    p = _verb(sub, "web", "a live browser console for every node's parameters (needs the web extra)")
    p.add_argument(
        "--bind", default="127.0.0.1:8800", metavar="HOST:PORT", help="where to listen (default %(default)s)"
    )
    p.add_argument("--read-only", action="store_true", help="serve no write endpoint")
    p.add_argument(
        "--token-file",
        metavar="FILE",
        help="a bearer token (one word, 16+ characters) required for writes; "
        "required on a non-loopback --bind, where reads need it too",
    )
    p.add_argument(
        "--allow-host",
        action="append",
        metavar="NAME",
        help="another name the console is reached under (checked against the Host header: "
        "a DNS alias or a proxy's name; the bind address is always allowed); repeatable",
    )

    _keystore(_verb(sub, "keystore", "secure mode: CAs, governance and identities; the secure Cyclone build"))

    _ros2(_verb(sub, "ros2", "mirror ROS 2 nodes on paramdds, expose paramdds nodes to ROS 2 (ros2 extra)"))

    from .verbs import zenoh as zenoh_verb  # argparse only (the verb imports Zenoh when it runs)

    zenoh_verb.add_arguments(_verb(sub, "zenoh", zenoh_verb.HELP))

    if with_bench:
        _register_bench(sub)
    else:
        sub.add_parser("bench", help="benchmarks (see 'paramdds bench --help')", add_help=False)
    return top


def _register_bench(sub: argparse._SubParsersAction[Parser]) -> None:
    """Let the bench module add its own parser, then give it the global options."""
    try:
        from ..bench.cli import register  # type: ignore[import-not-found,unused-ignore]
    except ImportError as exc:
        raise UsageError(f"the bench verb is not available in this installation ({exc})") from exc
    register(sub)
    bench = sub.choices.get("bench")
    if bench is not None:
        _add_globals(bench, top=False)


def find_verb(argv: Sequence[str]) -> str | None:
    """The first argument that names a verb (good enough to decide on lazy parts)."""
    return next((a for a in argv if a in VERBS), None)


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
