"""``paramdds get``: values of parameters; a name the node lacks is one line on stderr and exit 1.

NODE may be a glob (``fleet/*``; ``'east/*'`` over Zenoh): the values are then read from
one monitor's state (no call per node), a line ``NODE: NAME = VALUE`` each (``-o json``:
an object per node), a name a node lacks one line on stderr (exit 1), no online node
matching exit 3, and over Zenoh a known site that did not answer a line each (exit 3; 1
when it is only not granted to this client).
"""

from __future__ import annotations

import argparse

HELP = "values of parameters"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", metavar="NODE", help="a node, or a glob over nodes: 'fleet/*', 's1/*'")
    p.add_argument("names", nargs="+", metavar="NAME")


def run(args: argparse.Namespace) -> int:
    from ...core.jsonform import json_value
    from ...core.names import is_node_glob
    from ...session import Session
    from .._output import emit, report_missing, typed
    from .._values import names_arg, node_arg, node_glob_arg

    if is_node_glob(args.node):
        return run_glob(args, node_glob_arg(args.node), names_arg(args.names))
    node = node_arg(args.node)
    with Session(args) as session:
        reply = session.client().get(node, names_arg(args.names))
    found = [r for r in reply.results if r.code is None]
    emit(
        args.output,
        {r.name: json_value(r.value) for r in found},
        "\n".join(f"{r.name} = {typed(r.value)}" for r in found),
    )
    return report_missing(node, reply.missing())


def run_glob(args: argparse.Namespace, glob: str, names: list[str]) -> int:
    """``get GLOB NAME...``: the names of every online node matching ``glob``, from one monitor's state."""
    from ...core.jsonform import json_value
    from ...errors import UnavailableError
    from ...exits import Exit
    from ...session import Session
    from .._live import current_states
    from .._output import emit, problem, typed

    with Session(args) as session:
        states = current_states(session, [glob])
        missing = session.missing_sites()
    online = sorted((n, st) for n, st in states.items() if st.online)
    if not online and not missing:
        raise UnavailableError(f"no online node matches {glob}")
    data: dict[str, dict[str, object]] = {}
    lines: list[str] = []
    code = 0
    for node, st in online:
        data[node] = {}
        for name in names:
            held = st.parameters.get(name)
            if held is None:
                problem(f"{name}: not found on {node!r}")
                code = Exit.REFUSED
                continue
            data[node][name] = json_value(held[0])
            lines.append(f"{node}: {name} = {typed(held[0])}")
    emit(args.output, data, "\n".join(lines))
    if missing:
        from ...zenoh.completeness import lacking_exit, lacking_line

        for site, lack in missing.items():
            problem(lacking_line(site, lack))
        code = max(code, lacking_exit(missing))
    return code
