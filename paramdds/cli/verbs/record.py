"""``paramdds record``: every parameter change (all nodes, or those a glob matches), with its author, to MCAP.

The recorder lives in :mod:`paramdds.record`; this verb checks the extra and the
arguments and runs it. The file's channels are :mod:`paramdds.formats.recording`'s
(docs/foxglove.md, "Recording and replay").
"""

from __future__ import annotations

import argparse

HELP = "record every parameter change, with its author, to an MCAP file (needs the foxglove extra)"

OVERRIDES_GLOBALS = True  # -o is the file here, not the global output format (one format: MCAP)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("nodes", nargs="*", metavar="NODE", help="only these nodes, globs allowed (default: all)")
    p.add_argument("-o", dest="output_file", required=True, metavar="FILE.mcap", help="the file to write")
    p.add_argument(
        "--split",
        metavar="SIZE|DURATION",
        help="start a new file (FILE-0001.mcap, FILE-0002.mcap, …) at this size (100MB, 1GiB) "
        "or age (10m, 1h); each starts with every node's state",
    )


def run(args: argparse.Namespace) -> int:
    from .._extras import require_extra
    from .._values import node_glob_arg

    require_extra("'paramdds record'", "foxglove", ("mcap",))
    from ...record.serve import run_record

    return run_record(args, [node_glob_arg(n) for n in args.nodes])
