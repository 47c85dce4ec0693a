"""Parameter files as the front ends use them: read one for a node, whatever its format, and dump.

A file with a top-level ``parameters:`` list is a parameter list and applies to every
node; any other file is a ROS 2 parameter file and only the sections matching the node
apply. The CLI, the web console, the server process and the journal read and write
parameter files through these functions (pure: files in, values out; no DDS).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..core.descriptors import ParameterDescriptor
from ..core.values import Parameter, ParameterValue

Entry = tuple[str, ParameterValue, ParameterDescriptor | None]
Snapshot = list[tuple[str, ParameterValue, ParameterDescriptor]]



def _entries(items: Sequence[Any]) -> list[Entry]:
    """Normalise the loaders' entries to ``(name, value, descriptor or None)``."""
    out: list[Entry] = []
    for item in items:
        if isinstance(item, tuple):
            name, value, *rest = item
            out.append((name, value, rest[0] if rest else None))
        else:
            out.append((item.name, item.value, getattr(item, "descriptor", None)))
    return out


def is_param_list(text: str, source: str) -> bool:
    """True when the document is a map with a top-level ``parameters:`` list (a parameter list)."""
    import yaml

    from .base import Source, compose

    node = compose(text, Source(source))
    if not isinstance(node, yaml.MappingNode):
        return False
    return any(k.value == "parameters" and isinstance(v, yaml.SequenceNode) for k, v in node.value)


def read_entries(path: str, node_id: str) -> list[Entry]:
    """The entries a parameter file gives ``node_id``: every one of a parameter list, in file
    order, or those of the matching sections of a ROS 2 file."""
    from .base import read_file

    text = read_file(path)
    if is_param_list(text, path):
        from .paramlist import load_param_list_str

        return _entries(load_param_list_str(text, source=path))
    return parse_ros_text(text, path, node_id)


def parse_ros_text(text: str, source: str, node_id: str) -> list[Entry]:
    """The entries for ``node_id`` in a ROS 2 parameter file's text."""
    from .ros import load_ros_text_full

    return _entries(load_ros_text_full(text, node_id, source=source))


def read_values(path: str, node_id: str) -> list[Parameter]:
    """A parameter file as parameters to set on ``node_id``, in file order."""
    return [Parameter(name, value) for name, value, _ in read_entries(path, node_id)]


def dump_text(state: Mapping[str, Snapshot], *, with_descriptors: bool = True) -> str:
    """A ROS 2 parameter file holding every node of ``state`` (the dump format)."""
    from .dump import dump_ros_params

    return "".join(
        dump_ros_params(node, snapshot, with_descriptors=with_descriptors) for node, snapshot in state.items()
    )
