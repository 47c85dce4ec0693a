"""``paramdds nodes``: every node alive now, once the monitor holds their state (or a short wait).

Over Zenoh, a known site that did not answer is a row of its own (``SITE/*``, status
``no answer``, or ``not granted`` when the router refuses this client the site; its reason
under ``missing``) and a line on stderr, and the exit code is 3 (1 when every site lacking
is only not granted).
"""

from __future__ import annotations

import argparse

HELP = "every node alive now (or those of NODE globs): online, parameter count, host, pid, revision, origin"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "nodes",
        nargs="*",
        metavar="NODE",
        help="only these nodes, globs allowed: 'fleet/*', 's1/*' (default: all)",
    )


def run(args: argparse.Namespace) -> int:
    from ...core.names import shown_node
    from ...core.revision import Revision, incarnation_text
    from ...exits import Exit
    from ...session import Session
    from .._live import current_states
    from .._output import emit, problem
    from .._values import node_glob_arg

    nodes = [node_glob_arg(n) for n in args.nodes]
    with Session(args) as session:
        states = current_states(session, nodes)
        missing = session.missing_sites()
    rows: list[dict[str, object]] = [
        {
            "node": shown_node(st.node, st.origin),  # a ROS 2 node with its leading slash
            "online": st.online,
            "parameters": st.announced if st.announced >= 0 else len(st.parameters),
            "host": st.host,
            "pid": st.pid,
            "revision": st.revision,
            "also_hosted_by": list(st.duplicates),  # other processes hosting the same node id
            "request_filter": st.request_filter,  # "native", "handler", or None: the server does not say
            "incarnation": incarnation_text(st.incarnation),  # the server's for the node, new on every start
            "at": str(Revision(st.incarnation, st.revision)),  # what `set --if-revision` takes
            "origin": st.origin,  # the presence tag "origin" ("ros2": mirrored by the bridge), or None
            "status": st.status,  # "unreachable": a ROS 2 node the bridge cannot read; "stale": one
            # whose set waits on its stalled process (values are the last known); else None
        }
        for st in sorted(states.values(), key=lambda st: st.node)
        if st.online
    ]
    rows += [_missing_row(site, lack.reason, lack.refused) for site, lack in missing.items()]
    emit(args.output, rows, _nodes_table(rows))
    if missing:
        from ...zenoh.completeness import lacking_exit, lacking_line

        for site, lack in missing.items():
            problem(lacking_line(site, lack))
        return lacking_exit(missing)
    return Exit.OK


def _missing_row(site: str, reason: str, refused: bool) -> dict[str, object]:
    """A site lacking, as a row: its nodes are ``SITE/*``, status ``no answer`` (or ``not
    granted``: the router's access control refuses this client the site)."""
    return {
        "node": f"{site}/*",
        "online": False,
        "parameters": None,
        "host": None,
        "pid": None,
        "revision": None,
        "also_hosted_by": [],
        "request_filter": None,
        "incarnation": None,
        "at": None,
        "origin": None,
        "status": "not granted" if refused else "no answer",
        "missing": reason,
    }


def _nodes_table(rows: list[dict[str, object]]) -> str:
    header = ("NODE", "ONLINE", "PARAMS", "HOST", "PID", "REVISION", "ORIGIN")
    cells = [header] + [
        (
            str(r["node"]),
            str(r["status"] or ("yes" if r["online"] else "no")),
            _cell(r["parameters"]),
            _cell(r["host"]),
            _cell(r["pid"]),
            _cell(r["revision"]),
            str(r["origin"] or ("paramdds" if r["online"] else "-")),
        )
        for r in rows
    ]
    widths = [max(len(row[i]) for row in cells) for i in range(len(header))]
    lines = ("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells)
    return "\n".join(line.rstrip() for line in lines)


def _cell(value: object) -> str:
    return "-" if value is None else str(value)
