"""``paramdds keystore init|add|install``: secure mode's CAs, governance and identities, and the
secure Cyclone build (:mod:`paramdds.secure`)."""

from __future__ import annotations

import argparse

from .._parser import Parser

HELP = "secure mode: CAs, governance and identities; the secure Cyclone build"


def add_arguments(p: argparse.ArgumentParser) -> None:
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


def run(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    from ...exits import Exit, UsageError
    from .._extras import require_extra

    if args.action == "install":
        from ...secure.install import run as install

        return install(args)
    require_extra("'paramdds keystore'", "secure")
    from ...secure.keystore import KeystoreError, add_identity, init_keystore

    root = Path(args.keystore)
    try:
        if args.action == "init":
            init_keystore(root)
            sys.stdout.write(
                f"keystore {root}: identity and permissions CAs, governance (authentication required, "
                "discovery and data encrypted); add identities with 'paramdds keystore add'\n"
            )
        else:
            info = add_identity(root, args.name, args.role, args.nodes)
            sys.stdout.write(
                f"identity {info.name} ({info.role}, nodes {' '.join(info.nodes)}): --identity {info.path}\n"
            )
    except KeystoreError as exc:
        raise UsageError(str(exc)) from exc
    return Exit.OK
