"""Checking parameter files offline: against a JSON Schema (as Autoware's CI does with
check-jsonschema) or against a generate_parameter_library spec. No DDS.

A parameter file is read as plain data with ROS 2's scalar rules (:mod:`..scalar`:
``30`` an integer, ``0.5`` a double, ``true`` a bool, ``$(var x)`` a string; quoted
text a string; an empty value null) and the whole document is validated, envelope
included, so the verdict is check-jsonschema's. (check-jsonschema reads YAML 1.2,
where ``yes``/``on``/``y`` are strings and ``010`` is ten; ROS 2 reads them as bools
and eight, and so does this check: it judges what the node will get.) A parameter list
(a top-level ``parameters:`` list, which applies to every node) is checked as the ROS 2
file that says the same: its parameters in the section ``/**``, dotted names nested.

Autoware's convention (:func:`autoware_pairs`): ``<pkg>/schema/<name>.schema.json``
describes ``<pkg>/config/<name>*.param.yaml``.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ...core.validation import validate
from ...core.values import ParameterType, ParameterValue
from ...errors import FileFormatError, ParamddsError
from ..base import NONPLAIN_TAG, PLAIN_TAG, Source, compose, read_file
from ..files import is_param_list
from ..scalar import resolve_plain
from .enforce import NodeSchema
from .resolve import PARAMS_KEY

__all__ = ["Finding", "autoware_pairs", "check_with_schema", "check_with_spec", "read_document"]


@dataclass(frozen=True, slots=True)
class Finding:
    """One error in one file: the node section (``/**``), the parameter path, the reason."""

    file: str
    section: str
    path: str
    reason: str

    def __str__(self) -> str:
        return ": ".join(part for part in (self.file, self.section, self.path, self.reason) if part)


def read_document(path: str | Path, *, typed: bool = False) -> Any:
    """A YAML parameter file as plain data, scalars typed as ROS 2 types them; a parameter
    list as the ROS 2 file that says the same. ``typed`` keeps a parameter list's values as
    :class:`ParameterValue` (an empty list or a byte array keeps the type the file gives)."""
    name = str(path)
    source = Source(name)
    text = read_file(path)
    node = compose(text, source)
    if node is None:
        return None
    if is_param_list(text, name):
        from ..paramlist import load_param_list_str

        params = load_param_list_str(text, source=name)
        values = ((p.name, p.value if typed else _json_like(p.value)) for p in params)
        return {"/**": {PARAMS_KEY: _nested(values)}}
    return _plain(node, source)


def _json_like(value: ParameterValue) -> Any:
    """A value as plain data (a byte array as its list of integers)."""
    v = value.to_python()
    return list(v) if isinstance(v, bytes) else v


def _nested(items: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    """Dotted names as nested maps, as a ROS 2 file writes them; a name that is also the
    prefix of another (``a`` and ``a.b``) keeps the longer one as a dotted key beside it."""
    root: dict[str, Any] = {}
    for name, value in sorted(items, key=lambda item: item[0]):
        at, parts = root, name.split(".")
        while len(parts) > 1 and all(parts) and isinstance(at.get(parts[0], {}), dict):
            at = at.setdefault(parts[0], {})
            parts = parts[1:]
        at[".".join(parts)] = value
    return root


def _plain(node: yaml.Node, source: Source) -> Any:
    if isinstance(node, yaml.MappingNode):
        out: dict[str, Any] = {}
        for k, v in node.value:  # keys are names: never typed
            key = k.value if isinstance(k, yaml.ScalarNode) else str(_plain(k, source))
            out[str(key)] = _plain(v, source)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_plain(v, source) for v in node.value]
    assert isinstance(node, yaml.ScalarNode)
    text = str(node.value)
    if node.tag == PLAIN_TAG or (node.tag == NONPLAIN_TAG and node.style in ("|", ">")):
        if not text:
            return None
        return resolve_plain(text).value
    return text


def _sections(document: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """``(node key, ros__parameters)`` of every section, nested keys joined by ``/``."""
    if not isinstance(document, dict):
        return
    for key, value in document.items():
        if key == PARAMS_KEY:
            yield prefix or "/", value
        elif isinstance(value, dict):
            yield from _sections(value, f"{prefix}/{key}" if prefix else key)


def check_with_schema(schema: NodeSchema, path: str | Path) -> list[Finding]:
    """check-jsonschema's check of one file: every violation, in document order."""
    document = read_document(path)
    findings = []
    for v in schema.document_violations(document):
        section = _section_of(v.where)
        findings.append(Finding(str(path), section, v.path if section else "", v.message))
    return findings


def _section_of(where: str) -> str:
    """The node key of a violation's JSON path (``$./**.ros__parameters.x`` → ``/**``)."""
    rest = where[2:] if where.startswith("$.") else ""
    key, _, tail = rest.partition(".")
    return key if tail.startswith(PARAMS_KEY) else ""


def check_with_spec(spec: Any, path: str | Path) -> list[Finding]:
    """Every section of a parameter file against a generate_parameter_library spec: each
    value's type, ranges and validators, names the spec does not declare, required
    parameters without a value."""
    from ...core.values import NOT_SET

    document = read_document(path, typed=True)
    entries = {e.name: e for e in spec}
    mapped = [m.entry.name for m in getattr(spec, "mapped", ())]
    found: list[Finding] = []
    sections = list(_sections(document))
    given: dict[str, Any] = {}
    if not sections:
        found.append(
            Finding(
                str(path),
                "",
                "",
                f"no '{PARAMS_KEY}' section (neither a ROS 2 parameter file nor a 'parameters:' list)",
            )
        )
    for section, params in sections:
        values = dict(_flatten(params)) if isinstance(params, dict) else {}
        for name, raw in values.items():
            entry = entries.get(name)
            if entry is None:
                if not any(_mapped_match(pattern, name) for pattern in mapped):
                    found.append(Finding(str(path), section, name, "not declared by the spec"))
                continue
            try:
                value = _value(raw)
                desc = entry.descriptor
                if not desc.dynamic_typing:
                    value = value.coerce(desc.type, name=name)
                validate(name, value, desc)
            except ParamddsError as exc:
                found.append(Finding(str(path), section, name, exc.message))
        given.update(values)
    for name, entry in entries.items():  # sections merge for a node: any of them may give it
        if sections and entry.required and name not in given and entry.default is NOT_SET:
            found.append(
                Finding(str(path), "", name, "required by the spec (no default) and given by no section")
            )
    return found


def _mapped_match(pattern: str, name: str) -> bool:
    parts, segs = pattern.split("."), name.split(".")
    if len(parts) != len(segs):
        return False
    return all(p.startswith("__map_") or p == s for p, s in zip(parts, segs, strict=True))


def _flatten(params: dict[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    for key, value in params.items():
        name = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            yield from _flatten(value, name)
        else:
            yield name, value


def _value(raw: Any) -> ParameterValue:
    if raw is None:
        raise FileFormatError('no value (an empty YAML value); write "" for an empty string')
    numbers = isinstance(raw, list) and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in raw
    )
    if numbers and any(isinstance(x, float) for x in raw):
        raw = [float(x) for x in raw]  # rcl refuses a mixed list; the spec check judges the numbers
    if isinstance(raw, list) and not raw:
        return ParameterValue(ParameterType.STRING_ARRAY, ())
    return ParameterValue.from_python(raw)


def autoware_pairs(root: str | Path) -> list[tuple[Path, list[Path]]]:
    """Every ``schema/<name>.schema.json`` under ``root`` with its ``config/<name>*.param.yaml``."""
    out = []
    for schema in sorted(Path(root).rglob("schema/*.schema.json")):
        name = schema.name[: -len(".schema.json")]
        config = schema.parent.parent / "config"
        params = sorted(config.glob(f"{name}*.param.yaml")) if config.is_dir() else []
        out.append((schema, params))
    return out
