"""``paramdds history``: who changed what, and when: a node's changes and refused writes, newest last.

One line per record: the time (UTC), the revision, ``NAME: OLD → NEW`` (``(none)``: the
parameter did not exist; ``(deleted)``: the change deleted it), who and through
what (``alice (claimed) via cli``: a name the node could not verify is marked
``(claimed)``), and for a refused write the node's reason. ``-o json``: a list of
records (``node, name, revision, time, who, verified, via, old, new, outcome, reason``).

When retention dropped part of the range asked for, what is kept is printed and one
line on stderr says so: exit 1 (the node lacked something, as ``get`` of a missing name).
A node that keeps no history is one line, exit 1; a node that is not there, exit 3.

``--from FILE.mcap`` reads the node's changes from a recording (``paramdds record``)
instead of asking the node: the same lines; a node the recording lacks is exit 3, a
file that is not a recording exit 2, a file cut short one note line on stderr.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...core.history import HistoryRecord
    from ...core.values import ParameterValue
    from .._when import Point

HELP = "who changed what, and when: a node's past changes and refused writes"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE")
    p.add_argument("names", nargs="*", metavar="NAME", help="only these parameters (default: every one)")
    p.add_argument("--since", metavar="REV|TIME", help="after revision REV, or from TIME (ISO 8601, an age)")
    p.add_argument("--until", metavar="TIME", help="up to TIME (ISO 8601, or an age: 10m)")
    p.add_argument("--who", metavar="PATTERN", default="", help="only changes by these (a glob: '*@lab')")
    p.add_argument("--refused", action="store_true", help="only the writes the node refused")
    p.add_argument(
        "--from",
        dest="from_file",
        metavar="FILE.mcap",
        help="read the changes from a recording (paramdds record) instead of asking the node",
    )


def run(args: argparse.Namespace) -> int:
    from ...core.history import Outcome
    from ...exits import Exit
    from ...session import Session
    from .._output import emit, problem
    from .._values import names_arg, node_arg
    from .._when import parse_point, parse_time

    node = node_arg(args.node)
    names = names_arg(args.names)
    since = parse_point(args.since) if args.since is not None else None
    until = parse_time(args.until) if args.until is not None else None
    if args.from_file is not None:
        return _from_recording(args, node, names, since, until)
    with Session(args) as session:
        reply = session.client().history(
            node,
            names,
            since_revision=since.revision if since else None,
            since_time=since.time_s if since else None,
            until=until,
            who=args.who,
            outcome=Outcome.REFUSED if args.refused else Outcome.ALL,
        )
    records = list(reply.records)
    emit(args.output, [r.to_json() for r in records], "\n".join(history_line(r) for r in records))
    if reply.compacted:
        problem(compacted_line(node, records))
        return Exit.REFUSED
    return Exit.OK


def _from_recording(
    args: argparse.Namespace, node: str, names: list[str], since: Point | None, until: float | None
) -> int:
    """``history --from FILE.mcap``: the node's changes as the recording holds them."""
    from ...core.history import HistoryQuery, Outcome
    from ...errors import UnavailableError
    from ...exits import Exit
    from .._output import emit
    from .._recording import open_recording

    recording = open_recording(args.from_file)
    if node not in recording.nodes:
        raise UnavailableError(f"node {node!r} is not in the recording {args.from_file}")
    query = HistoryQuery(
        names=tuple(names),
        since_revision=since.revision if since else None,
        since_time_ns=round(since.time_s * 1e9) if since and since.time_s is not None else None,
        until_time_ns=round(until * 1e9) if until is not None else None,
        who=args.who,
        outcome=Outcome.REFUSED if args.refused else Outcome.ALL,
    )
    records = recording.history(node, query)
    emit(args.output, [r.to_json() for r in records], "\n".join(history_line(r) for r in records))
    return Exit.OK


def compacted_line(node: str, records: list[HistoryRecord]) -> str:
    """What ``history`` says on stderr when retention dropped part of the range asked for."""
    if not records:
        return f"retention dropped the history of node {node!r} asked for: none of it is kept"
    first = records[0]
    return (
        f"retention dropped part of the history of node {node!r} asked for: the oldest record "
        f"kept is at revision {first.revision} ({short_time(first.time_ns)})"
    )


def history_line(r: HistoryRecord) -> str:
    """``TIME  rev N  NAME: OLD → NEW  by WHO via VIA`` (and ``  REFUSED: REASON``)."""
    who = r.who if r.verified else f"{r.who} (claimed)"
    change = f"{r.name}: {_shown(r.old, '(none)')} → {_shown(r.new, '(deleted)')}"
    line = f"{short_time(r.time_ns)}  rev {r.revision}  {change}  by {who} via {r.via}"
    return line if r.applied else f"{line}  REFUSED: {r.reason or r.code}"


def short_time(time_ns: int) -> str:
    """UTC to the millisecond: ``2026-11-29T14:32:05.123Z``."""
    from ...core.history import iso_time

    text = iso_time(time_ns)
    return text[:23] + "Z"


def _shown(value: ParameterValue | None, absent: str) -> str:
    return absent if value is None else value.show()
