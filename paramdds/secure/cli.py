"""``paramdds keystore init|add|install``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..cli._errors import Exit, UsageError
from .keystore import KeystoreError, add_identity, init_keystore


def run_keystore(args: argparse.Namespace) -> int:
    if args.action == "install":
        from .install import run

        return run(args)
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
