"""``paramdds zenoh``: a site's gateway to Zenoh (or, with ``--router``, a small Zenoh router).

The gateway is an ordinary participant on the site's DDS domain (``-d``) and a Zenoh
session dialling out as a client (``--connect``) by default; see docs/zenoh.md.
"""

from __future__ import annotations

import argparse

HELP = "a site's gateway to Zenoh: its nodes' state and calls for remote clients (zenoh extra)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--site", metavar="NAME", help="this site's name (letters, digits, '_'); required for a gateway"
    )
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="a router to dial, e.g. tcp/10.0.0.1:7447; repeat",
    )
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="listen here too (peer or router mode)",
    )
    p.add_argument(
        "--mode",
        choices=("client", "peer", "router"),
        default=None,
        help="Zenoh mode (default client; router with --router)",
    )
    p.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="a Zenoh JSON5 configuration file (the options above override its keys)",
    )
    p.add_argument("--tls-ca", metavar="PEM", help="mutual TLS: the CA certificate every peer is signed by")
    p.add_argument("--tls-cert", metavar="PEM", help="mutual TLS: this side's certificate")
    p.add_argument("--tls-key", metavar="PEM", help="mutual TLS: this side's private key")
    p.add_argument(
        "--open-timeout",
        type=float,
        default=10.0,
        metavar="SECONDS",
        help="how long to try the --connect endpoints at start (default 10)",
    )
    p.add_argument(
        "--router",
        action="store_true",
        help="run only a Zenoh router session on --listen (tests, small set-ups; production runs zenohd)",
    )


def _options(args: argparse.Namespace) -> object:
    from ...errors import ParamddsError
    from ...zenoh.config import TlsFiles, ZenohOptions

    tls_parts = (args.tls_ca, args.tls_cert, args.tls_key)
    tls = None
    if any(tls_parts):
        if not all(tls_parts):
            raise ParamddsError("mutual TLS needs --tls-ca, --tls-cert and --tls-key together")
        tls = TlsFiles(args.tls_ca, args.tls_cert, args.tls_key)
    mode = args.mode or ("router" if args.router else "client")
    return ZenohOptions(
        mode=mode,
        connect=list(args.connect),
        listen=list(args.listen),
        config_file=args.zenoh_config,
        tls=tls,
        open_timeout=args.open_timeout,
    )


def run(args: argparse.Namespace) -> int:
    import sys

    from ...errors import ParamddsError
    from ...zenoh.config import ZenohOptions, open_session
    from .._errors import Exit, UsageError
    from .._live import wait_until_interrupted
    from .._session import Session

    try:
        options = _options(args)
        assert isinstance(options, ZenohOptions)
        options.check()
    except ParamddsError as exc:
        raise UsageError(exc.message) from None
    if args.router:
        if not options.listen:
            raise UsageError("--router needs --listen ENDPOINT")
        zsession = open_session(options)
        try:
            sys.stdout.write(f"[ZENOH] Router {zsession.zid()} listening on {', '.join(options.listen)}\n")
            sys.stdout.flush()
            wait_until_interrupted()
        finally:
            zsession.close()
        return Exit.OK
    if not args.site:
        raise UsageError("a gateway needs --site NAME")
    from ...zenoh.keys import check_site

    try:
        check_site(args.site)
    except ParamddsError as exc:
        raise UsageError(exc.message) from None
    from ...zenoh.gateway import Gateway

    zsession = open_session(options)
    gateway = None

    def on_role(active: bool) -> None:
        sys.stdout.write(
            f"[ZENOH] Site {args.site}: gateway {zsession.zid()} is {'active' if active else 'standby'}\n"
        )
        sys.stdout.flush()

    try:
        with Session(args, app_name="paramdds-zenoh") as session:
            gateway = Gateway(session.participant, zsession, args.site, qos=session.qos)
            gateway.on_role = on_role  # changes from now on (the line below says the first role)
            try:
                sys.stdout.write(
                    f"[ZENOH] Gateway for site {args.site} on domain {args.domain} "
                    f"({'active' if gateway.active else 'standby'}, zid {gateway.zid})\n"
                )
                sys.stdout.flush()
                wait_until_interrupted()
            finally:
                gateway.close()
    finally:
        zsession.close()
    return Exit.OK
