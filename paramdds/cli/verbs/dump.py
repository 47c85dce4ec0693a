"""``paramdds dump``: nodes' parameters as a ROS 2 parameter file on stdout (what ``load`` reads).

Several nodes, and globs (``fleet/*``; ``s1/*`` over Zenoh), give one file with a section
per node; a glob stands for the nodes online now that match it (none: exit 3). Without a
node it dumps every node online, from one monitor's state (no request per node), as
``ros2 param dump`` does; a file ``server -p`` and ``load`` read back.

Over Zenoh every node is read from the remote monitor's state (values and descriptors,
one state query per site), never with a call per node: what cannot be read (a node not
online, a known site that did not answer) is one line each on stderr and exit 3 (1 when
it is only sites not granted to this client), and the rest is written.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...dds.monitor import NodeState
    from ...session import Session
    from .._snapshot import Snapshot

HELP = "nodes' parameters as a ROS 2 parameter file on stdout"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "nodes",
        nargs="*",
        metavar="NODE",
        help="nodes, globs allowed: 'fleet/*', 's1/*' (default: every node online)",
    )
    p.add_argument("--descriptors", action="store_true", help="add the descriptors (a map ROS 2 cannot read)")
    # the default; still accepted, so scripts that pass it keep working
    p.add_argument("--no-descriptors", action="store_true", help=argparse.SUPPRESS)


def run(args: argparse.Namespace) -> int:
    import sys

    from ...core.names import is_node_glob
    from ...errors import UnavailableError
    from ...formats.files import dump_text
    from ...session import Session
    from .._live import current_states
    from .._output import report_missing
    from .._snapshot import snapshot_of
    from .._values import node_glob_arg

    patterns = [node_glob_arg(n) for n in args.nodes]
    globs = [p for p in patterns if is_node_glob(p)]
    snapshots: dict[str, Snapshot] = {}
    code = 0
    with Session(args) as session:
        if getattr(args, "zenoh", None):
            snapshots, code = remote_snapshots(session, patterns)
            patterns = globs = []  # read from the state above
        elif not patterns:
            snapshots = every_snapshot(session)
            if not snapshots:
                raise UnavailableError("no node is online")
        targets = [p for p in patterns if not is_node_glob(p)]
        if globs:
            online = sorted(n for n, st in current_states(session, globs).items() if st.online)
            if not online:
                raise UnavailableError(f"no online node matches {' '.join(globs)}")
            targets += online
        if targets:
            client = session.client()
            for node in dict.fromkeys(targets):  # each node once, in order
                snapshots[node], missing = snapshot_of(client, node)
                code = max(code, report_missing(node, missing))
    sys.stdout.write(dump_text(snapshots, with_descriptors=args.descriptors))
    sys.stdout.flush()
    return code


def every_snapshot(session: Session) -> dict[str, Snapshot]:
    """Every online node's parameters with a value, by node in order, from one monitor's state."""
    from .._live import current_states

    states = current_states(session)
    return {st.node: _held(st) for st in sorted(states.values(), key=lambda st: st.node) if st.online}


def remote_snapshots(session: Session, patterns: list[str]) -> tuple[dict[str, Snapshot], int]:
    """The nodes of ``patterns`` (every node when empty) online in one remote monitor's state,
    exact names in their order then each glob's matches, and the exit code: 3 when a node
    named is not online or a known site did not answer (each said on stderr)."""
    from ...core.names import is_node_glob
    from ...errors import UnavailableError
    from ...exits import Exit
    from ...zenoh.completeness import lacking_exit, lacking_line
    from .._live import current_states
    from .._output import problem

    states = current_states(session, patterns)
    missing = session.missing_sites()
    from ...zenoh.monitor import remote_filter

    names = [remote_filter([p]).patterns()[0] for p in patterns if not is_node_glob(p)]  # SITE/NODE, in order
    unread = [n for n in names if n not in states or not states[n].online]
    matched = sorted(n for n, st in states.items() if st.online and n not in names)
    snapshots = {n: _held(states[n]) for n in dict.fromkeys(names + matched) if n not in unread}
    if not snapshots and not unread and not missing:
        globs = [p for p in patterns if is_node_glob(p)]
        raise UnavailableError(f"no online node matches {' '.join(globs)}" if globs else "no node is online")
    for node in unread:
        state = states.get(node)
        problem(f"node {node!r} is {'offline' if state is not None else 'not present'}: not dumped")
    for site, lack in missing.items():
        problem(lacking_line(site, lack))
    return snapshots, Exit.UNREACHABLE if unread else lacking_exit(missing)


def _held(st: NodeState) -> Snapshot:
    """A node's parameters with a value, by name, as the monitor holds them."""
    from ...core.values import ParameterType

    return [
        (name, value, descriptor)
        for name, (value, descriptor) in sorted(st.parameters.items())
        if value.type is not ParameterType.NOT_SET  # no value: left out, as a get leaves it
    ]
