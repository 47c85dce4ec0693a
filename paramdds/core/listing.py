"""Listing parameter names by prefix and depth: rclcpp's ``list_parameters``, ported.

The algorithm, exactly as ``rclcpp::node_interfaces::NodeParameters::list_parameters``:

* The separator is ``.``. ``depth`` 0 is ``DEPTH_RECURSIVE`` (no limit).
* With no prefixes and depth 0, every name is listed.
* With no prefixes and depth ``d``, a name is listed when it holds fewer than ``d``
  separators (depth 1 lists the top-level names).
* With prefixes, a name is listed when it equals one of them, or starts with
  ``prefix + "."`` and (depth 0, or the rest after ``prefix + "."`` holds fewer than
  ``d`` separators).
* Names come in sorted order (rclcpp iterates a ``std::map``). For each listed
  name holding a separator, the part before its *last* separator is a prefix;
  prefixes are reported once each, in order of first appearance.

A prefix that does not match any name simply lists nothing (as in ROS 2).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

__all__ = ["SEPARATOR", "list_names"]

SEPARATOR = "."


def list_names(
    sorted_names: Iterable[str], prefixes: Sequence[str] = (), depth: int = 0
) -> tuple[list[str], list[str]]:
    """``(names, prefixes)`` for names given in sorted order (see the module docstring)."""
    if depth < 0:
        raise ValueError("depth must be >= 0 (0 lists recursively)")
    names: list[str] = []
    found: dict[str, None] = {}  # an ordered set
    recursive = not prefixes and depth == 0
    dotted = [p + SEPARATOR for p in prefixes]
    for name in sorted_names:
        if not recursive and not _selected(name, prefixes, dotted, depth):
            continue
        names.append(name)
        cut = name.rfind(SEPARATOR)
        if cut >= 0:
            found.setdefault(name[:cut])
    return names, list(found)


def _selected(name: str, prefixes: Sequence[str], dotted: Sequence[str], depth: int) -> bool:
    if not prefixes:
        return name.count(SEPARATOR) < depth
    for prefix, with_dot in zip(prefixes, dotted, strict=True):
        if name == prefix:
            return True
        if name.startswith(with_dot) and (depth == 0 or name.count(SEPARATOR, len(with_dot)) < depth):
            return True
    return False
