"""Reading YAML into composed nodes, and the one place PyYAML errors become ours.

Every parameter format (parameter lists, ROS 2 files, specs, command-line values) is read
the same way: PyYAML *composes* the text into nodes with a loader whose implicit
resolvers are switched off, so no scalar is typed by YAML 1.1's rules (``1:20``
is never 80, ``yes`` is never guessed by PyYAML). Each untagged scalar arrives
with one of two marker tags:

* :data:`PLAIN_TAG` — a plain scalar, typed later by :mod:`.scalar`;
* :data:`NONPLAIN_TAG` — a quoted or block (``|``/``>``) scalar with no tag;
  quoted ones are strings, block ones are typed by content as rcl does.

An explicit ``!!str`` keeps PyYAML's ``tag:yaml.org,2002:str``. Nodes keep their
marks, so every error names ``file:line`` (``start_mark.line + 1``).

Failures are mapped here, once: a YAML syntax error, a file that cannot be read
or is not UTF-8 all become :class:`~paramdds.errors.FileFormatError`.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

from ..errors import FileFormatError

PLAIN_TAG = "tag:paramdds:plain"
NONPLAIN_TAG = "tag:paramdds:nonplain"
STR_TAG = "tag:yaml.org,2002:str"
SEQ_TAG = "tag:yaml.org,2002:seq"
MAP_TAG = "tag:yaml.org,2002:map"

_Base: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_Base):  # type: ignore[misc]
    """A composer only: plain scalars get :data:`PLAIN_TAG`, nothing is guessed."""

    def resolve(self, kind: Any, value: Any, implicit: Any) -> str:
        if kind is yaml.ScalarNode:
            return PLAIN_TAG if implicit[0] else NONPLAIN_TAG
        if kind is yaml.SequenceNode:
            return SEQ_TAG
        return MAP_TAG


class Source:
    """Where a document came from: a file path or a label such as ``<string>``."""

    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        self.name = name

    def error(
        self, message: str, node: yaml.Node | None = None, *, line: int | None = None
    ) -> FileFormatError:
        """A :class:`FileFormatError` at ``node``'s line (or ``line``)."""
        if node is not None:
            line = node.start_mark.line + 1
        return FileFormatError(message, file=self.name, line=line)


def line_of(node: yaml.Node) -> int:
    return int(node.start_mark.line) + 1


def read_file(path: str | Path) -> str:
    """The text of ``path`` (UTF-8, a BOM allowed); any failure is a FileFormatError."""
    name = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise FileFormatError(f"cannot read the file: {exc.strerror or exc}", file=name) from exc
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise FileFormatError(f"the file is not UTF-8 ({exc.reason})", file=name, line=line) from exc


def compose(text: str, source: Source, *, aliases: bool = False) -> yaml.Node | None:
    """One YAML document as nodes (``None`` when empty); syntax errors name the line.

    An alias (``*name``) is refused unless ``aliases``, as rcl_yaml_param_parser refuses it
    (PyYAML, which generate_parameter_library reads specs with, accepts it).
    """
    try:
        node: yaml.Node | None = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        what = " ".join(str(p) for p in (exc.context, exc.problem) if p)
        raise FileFormatError(f"YAML syntax error: {what}", file=source.name, line=line) from exc
    except yaml.YAMLError as exc:
        raise FileFormatError(f"YAML error: {exc}", file=source.name) from exc
    if node is not None and not aliases:
        _refuse_aliases(node, source)
    return node


def _refuse_aliases(root: yaml.Node, source: Source) -> None:
    """An alias composes to the very node its anchor names: a node met twice is an alias."""
    seen: set[int] = set()
    stack = [root]
    while stack:
        node = stack.pop()
        if id(node) in seen:
            raise source.error(
                "YAML anchors and aliases (&name, *name) are not supported in parameter files "
                "(ROS 2's parser refuses them too); write the value out",
                node,
            )
        seen.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
        elif isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                stack.extend((k, v))


def key_text(key: yaml.Node, source: Source, where: str) -> str:
    """A mapping key as text: any scalar, taken literally (as rcl does); never empty."""
    if not isinstance(key, yaml.ScalarNode):
        raise source.error(f"{where}: a key must be a plain word, not a list or map", key)
    if key.tag not in (PLAIN_TAG, NONPLAIN_TAG, STR_TAG):
        raise source.error(f"{where}: unsupported tag {key.tag!r} on key {key.value!r}", key)
    text = str(key.value)
    if not text:
        raise source.error(f"{where}: empty key", key)
    if text == "<<" and key.tag == PLAIN_TAG:
        raise source.error(f"{where}: YAML merge keys (<<) are not supported", key)
    return text


def items(node: yaml.MappingNode, source: Source, where: str) -> Iterator[tuple[str, yaml.Node, yaml.Node]]:
    """``(key, key_node, value_node)`` of a map in file order; a repeated key is an error.

    PyYAML (and rcl) keep the last of two equal keys silently; we refuse them.
    """
    seen: dict[str, int] = {}
    for knode, vnode in node.value:
        key = key_text(knode, source, where)
        if key in seen:
            raise source.error(f"{where}: key {key!r} is repeated (first at line {seen[key]})", knode)
        seen[key] = line_of(knode)
        yield key, knode, vnode


def expect_map(node: yaml.Node, source: Source, where: str) -> yaml.MappingNode:
    if not isinstance(node, yaml.MappingNode):
        raise source.error(f"{where}: expected a map", node)
    return node
