"""The verbs of ``paramdds``, one module each, registered in :data:`VERBS` (as ros2cli does).

A verb is a module ``paramdds/cli/verbs/<verb>.py`` with::

    HELP = "one line"                                    # the verb's line in `paramdds --help`
    def add_arguments(p: argparse.ArgumentParser) -> None: ...
    def run(args: argparse.Namespace) -> int: ...        # the exit code

Its module top imports argparse and nothing heavy (every verb module is imported to
build the parser, so ``paramdds --help`` stays fast); ``run`` imports Cyclone, the DDS
layer and whatever else it needs. The global options (``-d``, ``-o``, ``--timeout``…)
are added to every verb's parser by :func:`paramdds.cli._parser.build_parser`; errors
raised by ``run`` become exit codes in :func:`paramdds.cli.main`. Adding a verb is
one module and one line below.
"""

from __future__ import annotations

import argparse
import importlib
from typing import Protocol, cast

# the order of `paramdds --help`
VERBS = (
    "server",
    "demo",
    "nodes",
    "list",
    "get",
    "describe",
    "delete",
    "set",
    "dump",
    "load",
    "watch",
    "history",
    "diff",
    "assign",
    "web",
    "foxglove",
    "record",
    "keystore",
    "ros2",
    "zenoh",
    "bench",
    "check",
    "schema",
)


class Verb(Protocol):
    """What a verb module provides."""

    HELP: str

    def add_arguments(self, p: argparse.ArgumentParser) -> None: ...

    def run(self, args: argparse.Namespace) -> int: ...


#: other names a verb answers to: ``client`` is what ``run.sh`` and the first releases called the demo
ALIASES = {"demo": ("client",)}
CANONICAL = {alias: name for name, aliases in ALIASES.items() for alias in aliases}


def verb(name: str) -> Verb:
    """The module of verb ``name`` (one of :data:`VERBS`, or an alias of one)."""
    return cast(Verb, importlib.import_module(f"{__name__}.{CANONICAL.get(name, name)}"))
