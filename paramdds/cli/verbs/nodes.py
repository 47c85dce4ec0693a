"""``paramdds nodes``: every node alive now, once the monitor holds their state (or a short wait)."""

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
    from .._output import emit
    from .._values import node_glob_arg

    nodes = [node_glob_arg(n) for n in args.nodes]
    with Session(args) as session:
        states = current_states(session, nodes)
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
    emit(args.output, rows, _nodes_table(rows))
    return Exit.OK


def _nodes_table(rows: list[dict[str, object]]) -> str:
    header = ("NODE", "ONLINE", "PARAMS", "HOST", "PID", "REVISION", "ORIGIN")
    cells = [header] + [
        (
            str(r["node"]),
            str(r["status"] or ("yes" if r["online"] else "no")),
            str(r["parameters"]),
            str(r["host"]),
            str(r["pid"]),
            str(r["revision"]),
            str(r["origin"] or "paramdds"),
        )
        for r in rows
    ]
    widths = [max(len(row[i]) for row in cells) for i in range(len(header))]
    lines = ("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in cells)
    return "\n".join(line.rstrip() for line in lines)
