"""Parameter names and node ids: what is allowed, checked in one place.

Parameter names
    A name is one or more *segments* joined by ``.``: ``robot.max_velocity``.
    No segment may be empty, so a name never starts or ends with ``.`` and never
    holds ``..``. A segment is made of ASCII letters, digits, ``_``, ``-`` and
    ``/`` (ROS 2 itself uses names such as
    ``qos_overrides./parameter_events.publisher.depth``). A name is at most
    :data:`~paramdds.core.limits.MAX_NAME_BYTES` (255) bytes of UTF-8. Only ASCII
    is accepted so that a name reads the same in a shell, a YAML file and a DDS
    key, whatever the locale.

Node ids
    A node id is one or more segments joined by ``/``: ``robot1``, ``ns/robot1``.
    A segment is made of ASCII letters, digits and ``_`` and is never empty. One
    leading ``/`` is accepted and dropped, so ``/robot1`` and ``robot1`` name the
    same node; the canonical form (the DDS key) has no leading slash. At most
    :data:`~paramdds.core.limits.MAX_NODE_ID_BYTES` (255) bytes.

Node globs
    Where a command or a monitor takes several nodes, each may be a glob
    (:class:`NodeFilter`): ``*`` and ``?`` match any characters (``/`` included, so
    ``s1/*`` is every node of site ``s1`` over Zenoh, ``fleet/*`` every node under
    ``fleet``) and ``[...]`` one of a set, as :func:`fnmatch.fnmatchcase`. A glob is
    checked as a node id with its wildcards read as letters.

Both checks raise :class:`~paramdds.errors.InvalidNameError` with a message that
says which rule the name broke.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from fnmatch import fnmatchcase

from ..errors import InvalidNameError
from .limits import MAX_NAME_BYTES, MAX_NODE_ID_BYTES

__all__ = ["NodeFilter", "canonical_node_id", "is_node_glob", "is_valid_name", "validate_name"]

_SEGMENT = re.compile(r"[A-Za-z0-9_\-/]+")
_NAME = re.compile(r"[A-Za-z0-9_\-/]+(?:\.[A-Za-z0-9_\-/]+)*")
_NODE_SEGMENT = re.compile(r"[A-Za-z0-9_]+")
_NODE_ID = re.compile(r"[A-Za-z0-9_]+(?:/[A-Za-z0-9_]+)*")
_WILDCARDS = re.compile(r"\[[^\]]*\]|[*?]")


def _shown(raw: str) -> str:
    return repr(raw) if len(raw) <= 80 else repr(raw[:77]) + "..."


def is_valid_name(name: object) -> bool:
    """True when :func:`validate_name` would accept ``name`` (fast path, no message)."""
    return isinstance(name, str) and _NAME.fullmatch(name) is not None and len(name) <= MAX_NAME_BYTES


def validate_name(name: object) -> str:
    """Return ``name`` if it is a valid parameter name, else raise InvalidNameError."""
    if is_valid_name(name):
        assert isinstance(name, str)
        return name
    if not isinstance(name, str):
        raise InvalidNameError(f"a parameter name must be a string, got {type(name).__name__}")
    if not name:
        raise InvalidNameError("a parameter name cannot be empty")
    size = len(name.encode("utf-8", "surrogatepass"))
    if size > MAX_NAME_BYTES:
        raise InvalidNameError(
            f"parameter name {_shown(name)} is {size} bytes long; the limit is {MAX_NAME_BYTES}"
        )
    for segment in name.split("."):
        if not segment:
            raise InvalidNameError(
                f"parameter name {_shown(name)} has an empty segment (no leading, trailing or doubled '.')"
            )
        if not _SEGMENT.fullmatch(segment):
            bad = next(c for c in segment if not _SEGMENT.fullmatch(c))
            raise InvalidNameError(
                f"parameter name {_shown(name)} contains {bad!r}; "
                "allowed are ASCII letters, digits, '_', '-', '/' and '.' between segments"
            )
    raise InvalidNameError(f"invalid parameter name {_shown(name)}")  # pragma: no cover


def canonical_node_id(raw: object) -> str:
    """The canonical form of a node id (no leading ``/``), or InvalidNameError."""
    if not isinstance(raw, str):
        raise InvalidNameError(f"a node id must be a string, got {type(raw).__name__}")
    node_id = raw[1:] if raw.startswith("/") else raw
    if _NODE_ID.fullmatch(node_id) and len(node_id) <= MAX_NODE_ID_BYTES:
        return node_id
    if not node_id:
        raise InvalidNameError("a node id cannot be empty")
    size = len(node_id.encode("utf-8", "surrogatepass"))
    if size > MAX_NODE_ID_BYTES:
        raise InvalidNameError(
            f"node id {_shown(raw)} is {size} bytes long; the limit is {MAX_NODE_ID_BYTES}"
        )
    for segment in node_id.split("/"):
        if not segment:
            raise InvalidNameError(f"node id {_shown(raw)} has an empty segment (no trailing or doubled '/')")
        if not _NODE_SEGMENT.fullmatch(segment):
            bad = next(c for c in segment if not _NODE_SEGMENT.fullmatch(c))
            raise InvalidNameError(
                f"node id {_shown(raw)} contains {bad!r}; allowed are ASCII letters, digits, '_' "
                "and '/' between segments"
            )
    raise InvalidNameError(f"invalid node id {_shown(raw)}")  # pragma: no cover


def is_node_glob(text: str) -> bool:
    """True when ``text`` holds a wildcard (``*``, ``?`` or ``[``): a pattern, not a node id."""
    return any(c in text for c in "*?[")


def canonical_node_glob(raw: str) -> str:
    """A node id (:func:`canonical_node_id`) or a node glob, without a leading ``/``."""
    if not is_node_glob(raw):
        return canonical_node_id(raw)
    glob = raw[1:] if raw.startswith("/") else raw
    letters = _WILDCARDS.sub("x", glob)
    try:
        canonical_node_id(letters)
    except InvalidNameError as exc:  # said of the glob, not of its wildcards read as letters
        why = exc.message.replace(f"node id {_shown(letters)} ", "")
        raise InvalidNameError(f"invalid node glob {_shown(raw)}: {why}") from None
    return glob


class NodeFilter:
    """Node ids and node globs: ``node in NodeFilter(["robot1", "s1/*"])``."""

    def __init__(self, patterns: Iterable[str]) -> None:
        self.exact: set[str] = set()
        self.globs: list[str] = []
        for raw in patterns:
            text = canonical_node_glob(raw)
            (self.globs.append if is_node_glob(text) else self.exact.add)(text)

    def __contains__(self, node: object) -> bool:
        return node in self.exact or (isinstance(node, str) and any(fnmatchcase(node, g) for g in self.globs))

    def patterns(self) -> list[str]:
        return sorted(self.exact) + self.globs


def shown_node(node: str, origin: str | None) -> str:
    """A node id as an operator knows it: a ROS 2 node (mirrored by the bridge, origin
    ``ros2``) with its leading slash (``/arm/driver``), a paramdds node without
    (``robot1``). Both forms are accepted wherever a node is given."""
    return "/" + node if origin == "ros2" else node
