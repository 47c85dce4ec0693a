"""``paramdds schema``: a draft-07 JSON Schema in Autoware's envelope, on stdout.

From a generate_parameter_library spec (``--spec FILE``: its defaults; a parameter
without one is ``required``), or from a live node's descriptors (``paramdds schema
NODE``: its current values are the defaults, every parameter with a value is
``required``, and the node key is the node's own name so that its ``paramdds dump``
validates; ``--node-key '/**'`` writes Autoware's wildcard instead).
"""

from __future__ import annotations

import argparse
import json
import sys

HELP = "derive a JSON Schema (draft-07, Autoware's envelope) from a spec or a live node"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("node", nargs="?", metavar="NODE", help="a live node (its descriptors)")
    p.add_argument("--spec", metavar="FILE", help="a generate_parameter_library spec instead of a node")
    p.add_argument("--node-key", metavar="KEY", help="the node key of the envelope (default: /** for a spec)")
    p.add_argument("--title", metavar="NAME", help="the definition's name (default: the node or spec name)")


def run(args: argparse.Namespace) -> int:
    from ...exits import UsageError
    from ...formats.ros import DESCRIPTORS_KEY
    from ...formats.schema.export import derive_schema

    if bool(args.spec) == bool(args.node):
        raise UsageError("give a NODE or --spec FILE (one of them)")
    if args.spec:
        from pathlib import Path

        from ...formats.spec import load_spec

        spec = load_spec(args.spec)
        title = args.title or Path(args.spec).name.split(".")[0]
        params = [(e.name, None if e.required else e.default, e.descriptor) for e in spec]
        params += [(m.entry.name, m.entry.default, m.entry.descriptor) for m in spec.mapped]
        schema = derive_schema(
            params,
            title=title,
            node_key=args.node_key or "/**",
            required=[e.name for e in spec if e.required],
        )
    else:
        from ...core.values import ParameterType
        from .._snapshot import node_snapshot
        from .._values import node_arg

        node = node_arg(args.node)
        snapshot, _ = node_snapshot(args, node)  # a name gone between list and get is simply not in it
        has_value = [
            n for n, v, d in snapshot if v.type is not ParameterType.NOT_SET and not d.dynamic_typing
        ]
        schema = derive_schema(
            snapshot,
            title=args.title or node.replace("/", "_"),
            node_key=args.node_key or node,
            required=has_value,
            extra_node_keys={
                DESCRIPTORS_KEY: {"type": "object", "description": "paramdds dump's descriptors"}
            },
        )
    sys.stdout.write(json.dumps(schema, indent=2, ensure_ascii=False) + "\n")
    sys.stdout.flush()
    return 0
