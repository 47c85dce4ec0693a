"""``paramdds zenoh``: a site's gateway to Zenoh (or, with ``--router``, a small Zenoh router).

The gateway is an ordinary participant on the site's DDS domain (``-d``) and a Zenoh
session dialling out as a client (``--connect``) by default; see docs/zenoh.md. A gateway
whose router does not answer yet keeps trying (forever unless ``--open-timeout`` bounds
it), its DDS side already up, and serves its site once connected.
"""

from __future__ import annotations

import argparse

ROUTER_OPEN_TIMEOUT = 10.0  # seconds: a router's --connect endpoints (other routers) at its start
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
        default=None,
        metavar="SECONDS",
        help="give up (exit 3) when no router answered within SECONDS of the start "
        "(default: try forever, pausing 0.5 s doubling to 10 s between tries)",
    )
    p.add_argument(
        "--grant",
        action="append",
        default=[],
        metavar="CN=SITE[,SITE]",
        help="router with mutual TLS: the certificate named CN may use these sites' keys ('*': all); "
        "once one is given, everything else is denied. Repeat",
    )
    p.add_argument(
        "--issue-cert",
        metavar="NAME",
        help="issue a TLS certificate NAME from --keystore's CA into --out, then exit",
    )
    p.add_argument(
        "--keystore", metavar="DIR", help="with --issue-cert: a keystore made by 'paramdds keystore init'"
    )
    p.add_argument(
        "--host",
        action="append",
        default=[],
        metavar="ADDR",
        help="with --issue-cert: an IP or DNS name the holder is dialled at (a router); repeat",
    )
    p.add_argument("--out", metavar="DIR", help="with --issue-cert: where to write ca.pem, cert.pem, key.pem")
    p.add_argument(
        "--router",
        action="store_true",
        help="run only a Zenoh router session on --listen (tests, small set-ups; production runs zenohd)",
    )


def _options(args: argparse.Namespace) -> object:
    from ...errors import ParamddsError
    from ...zenoh.config import TRY_TIMEOUT, TlsFiles, ZenohOptions

    tls_parts = (args.tls_ca, args.tls_cert, args.tls_key)
    tls = None
    if any(tls_parts):
        if not all(tls_parts):
            raise ParamddsError("mutual TLS needs --tls-ca, --tls-cert and --tls-key together")
        tls = TlsFiles(args.tls_ca, args.tls_cert, args.tls_key)
    mode = args.mode or ("router" if args.router else "client")
    extra: dict[str, object] = {}
    if args.grant:
        from ...zenoh.acl import access_control, parse_grant

        if tls is None:
            raise ParamddsError(
                "--grant matches certificate names: it needs mutual TLS (--tls-ca, --tls-cert, --tls-key)"
            )
        extra["access_control"] = access_control(dict(parse_grant(g) for g in args.grant))
    return ZenohOptions(
        mode=mode,
        connect=list(args.connect),
        listen=list(args.listen),
        config_file=args.zenoh_config,
        tls=tls,
        open_timeout=(ROUTER_OPEN_TIMEOUT if args.router else TRY_TIMEOUT)
        if args.open_timeout is None
        else args.open_timeout,
        extra=extra,
    )


def run(args: argparse.Namespace) -> int:
    import sys

    from ...errors import ParamddsError
    from ...exits import Exit, UsageError
    from ...session import Session
    from ...zenoh.config import ZenohOptions, build_config, open_session, open_session_waiting
    from .._live import wait_until_interrupted

    if args.issue_cert:
        from pathlib import Path

        from ...zenoh.tls import issue
        from .._extras import require_extra

        if not args.keystore or not args.out:
            raise UsageError("--issue-cert needs --keystore DIR and --out DIR")
        require_extra("'paramdds zenoh --issue-cert'", "secure")
        out = issue(Path(args.keystore), args.issue_cert, args.host, Path(args.out))
        sys.stdout.write(f"[ZENOH] Certificate {args.issue_cert} in {out}: ca.pem cert.pem key.pem\n")
        return Exit.OK
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
    from ...zenoh.grant import probe_opener

    build_config(options)  # a bad configuration file: exit 2 at once, never after a wait
    with Session(args, app_name="paramdds-zenoh") as session:  # the DDS side first, at once
        zsession = open_session_waiting(options, args.open_timeout)

        def on_role(active: bool) -> None:
            sys.stdout.write(
                f"[ZENOH] Site {args.site}: gateway {zsession.zid()} is {'active' if active else 'standby'}\n"
            )
            sys.stdout.flush()

        try:
            probe = probe_opener(options)  # a second session asks the router for the gateway's token
            gateway = Gateway(session.participant, zsession, args.site, qos=session.qos, open_probe=probe)
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
