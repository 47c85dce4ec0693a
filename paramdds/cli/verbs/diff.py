"""``paramdds diff A B``: what differs between two sets of parameters, one line per parameter.

Each side is a node (``robot1``), a node as it was (``robot1@7``: at revision 7;
``robot1@2026-11-29T14:32:00Z`` or ``robot1@2h``: at that time, rebuilt from its
history), a glob over nodes (``'robot*'``, ``'site*/robot1'``: every online node that
matches, each compared with the other side), or a parameter file: any file ``server -p``
reads (a ROS 2 parameter file, a dump, a parameter list); a side with a dot in it is a
file (``robot1.yaml``, ``./robot1``). A file gives each node its sections' values.

One line per parameter that differs: ``NAME: A → B``, or ``NAME: only in SIDE (VALUE)``;
with a glob, a block per node that differs, under its name. A file's value is read as
the node's parameter holds it (a file's ``2`` for a double is ``2.0``, as ``load`` reads
it). Exit 0 when the sides are the same, 1 when they differ (as diff(1) does), 2 for
bad usage or a file that is not a parameter file (file and line named), 3 for a node
that is not there; a point a node's history no longer reaches (retention dropped it) or
a node that keeps no history is one line, exit 1; over Zenoh, a known site a glob did not
reach is one line each, exit 3 (as ``get``). ``-o json``: a list of blocks, one per
node compared: ``{"node", "a", "b", "equal", "differences": [{"name", "kind", "a", "b"}]}``.

``--from FILE.mcap``: the node sides are read from a recording (``paramdds record``):
``NODE`` as it was at the recording's end, ``NODE@REV`` / ``NODE@TIME`` rebuilt from its
snapshot and changes; a point before the recording is one line, exit 1.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...core.descriptors import ParameterDescriptor
    from ...core.diff import Difference
    from ...core.values import ParameterValue
    from ...dds.client import ParameterClient
    from ...session import Session
    from ...zenoh.completeness import Lack
    from .._when import Point

    Values = dict[str, ParameterValue]
    Descriptors = dict[str, ParameterDescriptor]

HELP = "what differs between nodes, files, dumps and nodes as they were (NODE@REV, NODE@TIME)"

ANY_NODE = "any_node"  # the node a file is read for when no side names one (its /** sections)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("a", metavar="A", help="a node, NODE@REV, NODE@TIME, a glob ('robot*') or a file")
    p.add_argument("b", metavar="B", help="the same kinds as A")
    p.add_argument(
        "--from",
        dest="from_file",
        metavar="FILE.mcap",
        help="read the nodes (as they were, and now: at the recording's end) from a recording",
    )


@dataclass(frozen=True)
class Side:
    """One side as given: a file (``path``), or a node or glob (``pattern``) now or at ``point``."""

    text: str
    path: str | None = None
    pattern: str | None = None
    point: Point | None = None

    @property
    def is_glob(self) -> bool:
        from ...core.names import is_node_glob

        return self.pattern is not None and is_node_glob(self.pattern)


@dataclass(frozen=True)
class Block:
    """One comparison: node ``node`` (a file's section, or a glob's match) on both sides."""

    node: str
    a: str
    b: str
    differences: list[Difference]


def parse_side(text: str) -> Side:
    """A side from the command line (UsageError, exit 2, when it is none of the kinds)."""
    from .._values import node_glob_arg
    from .._when import split_at

    node, point = split_at(text)
    if point is None and "." in text:
        return Side(text, path=text)
    return Side(text, pattern=node_glob_arg(node), point=point)


def run(args: argparse.Namespace) -> int:
    from ...core.diff import difference_json
    from ...exits import Exit, UsageError
    from .._output import emit

    a, b = parse_side(args.a), parse_side(args.b)
    if a.is_glob and b.is_glob:
        raise UsageError("diff compares a glob with one side: a node, a file or NODE@…, not another glob")
    missing: dict[str, Lack] = {}
    if a.path is not None and b.path is not None:
        blocks = files_blocks(a, b)
    elif args.from_file is not None:
        blocks = recording_blocks(args.from_file, a, b)
    else:
        from ...session import Session

        with Session(args) as session:
            blocks = node_blocks(session, a, b)
            missing = session.missing_sites()  # over Zenoh: a glob's sites that did not answer
    if args.output in ("json", "yaml"):
        emit(
            args.output,
            [
                {
                    "node": k.node,
                    "a": k.a,
                    "b": k.b,
                    "equal": not k.differences,
                    "differences": [difference_json(d) for d in k.differences],
                }
                for k in blocks
            ],
        )
    else:
        emit("table", None, blocks_text(blocks, by_node=a.is_glob or b.is_glob))
    code: int = Exit.REFUSED if any(k.differences for k in blocks) else Exit.OK
    if missing:
        from ...zenoh.completeness import lacking_exit, lacking_line
        from .._output import problem

        for site, lack in missing.items():
            problem(lacking_line(site, lack))
        code = max(code, lacking_exit(missing))
    return code


def blocks_text(blocks: list[Block], *, by_node: bool = False) -> str:
    """One block alone as its lines; several (or a glob's) as a ``NODE:`` header and indented
    lines each, the blocks without a difference left out."""
    if len(blocks) == 1 and not by_node:
        k = blocks[0]
        return "\n".join(difference_line(d, k.a, k.b) for d in k.differences)
    lines: list[str] = []
    for k in blocks:
        if k.differences:
            lines.append(f"{k.node}:")
            lines.extend(f"  {difference_line(d, k.a, k.b)}" for d in k.differences)
    return "\n".join(lines)


def difference_line(d: Difference, a: str, b: str) -> str:
    """``NAME: A → B`` or ``NAME: only in SIDE (VALUE)``."""
    if d.b is None:
        assert d.a is not None
        return f"{d.name}: only in {a} ({d.a.show()})"
    if d.a is None:
        return f"{d.name}: only in {b} ({d.b.show()})"
    return f"{d.name}: {d.a.show()} → {d.b.show()}"


# -- files ------------------------------------------------------------------------------


def file_nodes(path: str) -> list[str]:
    """The nodes a parameter file names, in order (none for a parameter list, or wildcards only)."""
    from ...formats.base import read_file
    from ...formats.files import is_param_list
    from ...formats.ros import node_keys

    text = read_file(path)
    if is_param_list(text, path):
        return []
    keys = [k[1:] if k.startswith("/") else k for k in node_keys(text, source=path)]
    return [k for k in keys if k and "*" not in k]


def file_values(path: str, node: str) -> Values:
    """What a parameter file gives ``node``: its values, by name."""
    from ...core.values import ParameterType
    from ...formats.files import read_entries

    return {n: v for n, v, _ in read_entries(path, node) if v.type is not ParameterType.NOT_SET}


def files_blocks(a: Side, b: Side) -> list[Block]:
    """Two files: every node either names (one comparison when neither names one)."""
    from ...core.diff import compare

    assert a.path is not None and b.path is not None
    nodes = list(dict.fromkeys(file_nodes(a.path) + file_nodes(b.path))) or [ANY_NODE]
    blocks = []
    for n in nodes:
        differences = compare(file_values(a.path, n), file_values(b.path, n))
        blocks.append(Block("" if n == ANY_NODE else n, a.text, b.text, differences))
    return blocks


# -- nodes ------------------------------------------------------------------------------


def node_blocks(session: Session, a: Side, b: Side) -> list[Block]:
    """At least one side is a node (or a glob, or a node as it was): one block per node."""
    from ...core.diff import compare

    client = session.client()
    if a.pattern is None or (b.is_glob and not a.is_glob):  # the node (or glob) side first
        return [Block(k.node, k.b, k.a, _swap(k.differences)) for k in node_blocks(session, b, a)]
    fixed: Values | None = None  # B's values when B is one node (or one node as it was)
    if b.path is None:
        ((b_node, (b_values, _)),) = _nodes_of(session, b).items()
        fixed = _rebuilt(client, b_node, b_values, b.point) if b.point is not None else b_values
    blocks: list[Block] = []
    for node, (values, descriptors) in _nodes_of(session, a).items():
        if a.point is not None:
            values = _rebuilt(client, node, values, a.point)
        if fixed is not None:
            other = fixed
        else:
            assert b.path is not None
            other = _fitted(file_values(b.path, node), descriptors)
        blocks.append(Block(node, node if a.is_glob else a.text, b.text, compare(values, other)))
    return blocks


def _nodes_of(session: Session, side: Side) -> dict[str, tuple[Values, Descriptors]]:
    """A node's values and descriptors now (exit 3 when it is not there), or every online
    node a glob matches, from one monitor's state."""
    from ...core.values import ParameterType
    from ...errors import UnavailableError
    from .._live import current_states
    from .._snapshot import snapshot_of

    assert side.pattern is not None
    if not side.is_glob:
        snapshot, _ = snapshot_of(session.client(), side.pattern)
        held = [(n, v, d) for n, v, d in snapshot if v.type is not ParameterType.NOT_SET]
        return {side.pattern: ({n: v for n, v, _ in held}, {n: d for n, _, d in held})}
    states = current_states(session, [side.pattern])
    online = {n: st for n, st in sorted(states.items()) if st.online}
    if not online:
        raise UnavailableError(f"no online node matches {side.pattern}")
    return {
        n: (
            {k: v for k, (v, _) in st.parameters.items() if v.type is not ParameterType.NOT_SET},
            {k: d for k, (_, d) in st.parameters.items()},
        )
        for n, st in online.items()
    }


def _rebuilt(client: ParameterClient, node: str, now: Values, point: Point) -> Values:
    """``node``'s values at ``point``, from its values now and its history since then."""
    from ...core.history import Outcome, rewind
    from ...core.values import ParameterType
    from ...errors import NoHistoryError

    reply = client.history(
        node, since_revision=point.revision, since_time=point.time_s, outcome=Outcome.APPLIED
    )
    if reply.compacted:
        oldest = f": the oldest kept is revision {reply.records[0].revision}" if reply.records else ""
        raise NoHistoryError(
            f"cannot rebuild node {node!r} at {point}: retention dropped its history before that{oldest}"
        )
    return {n: v for n, v in rewind(now, reply.records).items() if v.type is not ParameterType.NOT_SET}


# -- a recording ------------------------------------------------------------------------


def recording_blocks(path: str, a: Side, b: Side) -> list[Block]:
    """``--from FILE.mcap``: the node sides as the recording holds them (``NODE``: at its end;
    ``NODE@REV``, ``NODE@TIME``: as they were then), the same blocks as :func:`node_blocks`."""
    from ...core.diff import compare
    from .._recording import open_recording

    recording = open_recording(path)

    def states(side: Side) -> dict[str, tuple[Values, Descriptors]]:
        from ...core.names import NodeFilter
        from ...errors import NoHistoryError, UnavailableError

        assert side.pattern is not None
        wanted = NodeFilter([side.pattern])
        matched = [n for n in recording.nodes if n in wanted]
        if not matched:
            raise UnavailableError(f"no node of the recording {path} matches {side.pattern}")
        out = {}
        for node in matched:
            p = side.point
            state = recording.state_at(
                node,
                revision=p.revision if p else None,
                time_ns=round(p.time_s * 1e9) if p and p.time_s is not None else None,
            )
            if state is None:
                raise NoHistoryError(f"the recording {path} does not reach node {node!r} at {p}")
            out[node] = state
        return out

    if a.pattern is None or (b.is_glob and not a.is_glob):  # the node (or glob) side first
        return [Block(k.node, k.b, k.a, _swap(k.differences)) for k in recording_blocks(path, b, a)]
    fixed = next(iter(states(b).values()))[0] if b.path is None else None
    blocks = []
    for node, (values, descriptors) in states(a).items():
        if fixed is not None:
            other = fixed
        else:
            assert b.path is not None
            other = _fitted(file_values(b.path, node), descriptors)
        blocks.append(Block(node, node if a.is_glob else a.text, b.text, compare(values, other)))
    return blocks


def _fitted(values: Values, descriptors: Descriptors) -> Values:
    """A file's values as the node's parameters hold them (``2`` for a double is ``2.0``)."""
    from ...core.fit import fit_value
    from ...errors import ParamddsError

    out: Values = {}
    for name, value in values.items():
        try:
            out[name] = fit_value(name, value, descriptors.get(name))
        except ParamddsError:  # not a value of that parameter: shown as it is
            out[name] = value
    return out


def _swap(differences: list[Difference]) -> list[Difference]:
    from ...core.diff import Difference

    return [Difference(d.name, d.b, d.a) for d in differences]
