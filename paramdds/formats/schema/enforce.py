"""Enforcing a JSON Schema on a node's values: the violations, found whole or incrementally.

Validation is ``jsonschema``'s ``Draft7Validator`` (with its format checker, as
check-jsonschema), never a validator written here: the verdict on a node's values is
the verdict on the same values written as a parameter file (:meth:`NodeSchema.document`).
:meth:`NodeSchema.node_validator` is the table's whole-node validator: every set,
atomic set, delete or declaration that would leave the node invalid is refused with the
schema's own reason, found by validating only what the change can affect
(:meth:`NodeSchema.changed_violations`).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ...core.values import ParameterType, ParameterValue
from ...errors import FileFormatError, ParamddsError
from .describe import MAX_TEXT, SchemaEntry
from .resolve import ANNOTATION_KEYWORDS, PARAMS_KEY, brief, format_error

__all__ = ["NodeSchema", "Violation", "concerns", "nest", "to_json"]

T = ParameterType
# an object schema with only these checks its key set and each property on its own
_SEPARABLE = frozenset(
    {"type", "properties", "required", "additionalProperties", "patternProperties", "minProperties"}
    | {"maxProperties", "propertyNames"}
    | ANNOTATION_KEYWORDS
)


@dataclass(frozen=True, slots=True)
class Violation:
    """One reason the schema refuses a node's values: ``path`` is the dotted parameter path
    (``""`` for the node itself), ``where`` the JSON path in the document checked."""

    path: str
    message: str
    where: str = ""

    def __str__(self) -> str:
        return f"{self.path or '(node)'}: {self.message}"


@dataclass
class NodeSchema:
    """A loaded schema: its parameters (``entries``) and its validator."""

    file: str
    root: dict[str, Any]
    node_key: str
    entries: list[SchemaEntry] = field(default_factory=list)
    # properties left undeclared: a $ref that fails, an error only if a value needs it
    ref_errors: dict[str, FileFormatError] = field(default_factory=dict)
    lenient: bool = False
    _validator: Any = None
    _cache: dict[int, tuple[Any, Any]] = field(default_factory=dict)  # id(sub-schema) -> validators
    _refs: dict[int, tuple[Any, Any, Any]] = field(default_factory=dict)  # id($ref node) -> its target

    # --- validating ----------------------------------------------------------------------

    def document_violations(self, document: object) -> list[Violation]:
        """What the schema says of a whole parameter file (the YAML as plain data):
        check-jsonschema's check. A ``$ref`` that fails here is a FileFormatError."""
        import referencing.exceptions

        try:
            errors = list(self._validator.iter_errors(document))
        except referencing.exceptions.Unresolvable as exc:
            raise _unresolvable(self.file, getattr(exc, "_wrapped", exc)) from None
        except RecursionError:
            raise format_error(self.file, "", "the schema recurses without end (a $ref cycle)") from None
        return [_violation(e) for e in sorted(errors, key=_order)]

    def violations(self, values: Mapping[str, ParameterValue]) -> list[Violation]:
        """What the schema says of a node holding ``values`` (unset ones are absent)."""
        return self.document_violations(self.document(values))

    def changed_violations(
        self,
        values: Mapping[str, ParameterValue],
        before: Mapping[str, ParameterValue | None],
        mirror: _Mirror | None = None,
    ) -> list[Violation]:
        """:meth:`violations`, for a node whose values were valid before the names of
        ``before`` changed (``before``: their values then, None when absent).

        The same verdict, found by validating only what the change can affect: along the
        path to each changed name, an object whose keywords are all *separable* (``type``,
        ``properties``, ``required``, ``additionalProperties``, ``patternProperties``,
        ``min/maxProperties``, ``propertyNames``: each checks the key set or one property
        alone) is checked for its key set and descended into; any other subschema (a leaf,
        or an object with ``oneOf``, ``dependencies``, ``not``…) is validated whole by
        jsonschema. Everything off those paths was valid and did not change. ``mirror`` keeps
        the nested document between calls (patched, not rebuilt)."""
        import referencing.exceptions

        names = list(before)
        keys_changed = any(_present(before, n) != _present(values, n) for n in names)
        params = mirror.update(values) if mirror is not None else nest(values)
        document = {self.node_key: {PARAMS_KEY: params}}
        paths = [(self.node_key, PARAMS_KEY, *n.split(".")) for n in names]
        for name in names:
            value = values.get(name)
            if value is not None and value.type is not T.NOT_SET and not _nested_at(params, name.split(".")):
                return self.document_violations(document)  # a dotted key (a name also a prefix)
        root, resolver = self._validator.schema, self._validator._resolver
        try:
            if mirror is None or keys_changed:
                errors = self._descend(root, resolver, document, (), paths, 0, keys_changed)
            else:  # values only: each name's plan (the subschemas validated whole) is fixed
                steps: dict[tuple[Any, ...], Any] = {}
                for name, path in zip(names, paths, strict=True):
                    plan = mirror.plans.get(name)
                    if plan is None:
                        plan = mirror.plans[name] = []
                        self._descend(root, resolver, document, (), [path], 0, False, plan)
                    steps.update(plan)
                errors = [
                    (prefix, e)
                    for prefix, whole in steps.items()
                    for e in whole.iter_errors(_at(document, prefix))
                ]
        except referencing.exceptions.Unresolvable as exc:
            raise _unresolvable(self.file, getattr(exc, "_wrapped", exc)) from None
        except RecursionError:
            raise format_error(self.file, "", "the schema recurses without end (a $ref cycle)") from None
        return [_violation(e, prefix) for prefix, e in sorted(errors, key=lambda pe: _order(pe[1], pe[0]))]

    def _validators_for(self, node: Any, resolver: Any) -> tuple[Any, Any]:
        """(the whole subschema's validator, its key-set-only validator), cached per subschema."""
        cached = self._cache.get(id(node))
        if cached is not None and cached[0].schema is node:
            return cached
        whole = self._validator.evolve(schema=node, _resolver=resolver)
        reduced = None
        if isinstance(node, dict):
            keyset = ("type", "required", "minProperties", "maxProperties", "propertyNames")
            keys = {k: node[k] for k in keyset if k in node}
            if "additionalProperties" in node:
                keys["properties"] = dict.fromkeys(node.get("properties", {}), True)
                keys["patternProperties"] = dict.fromkeys(node.get("patternProperties", {}), True)
                keys["additionalProperties"] = node["additionalProperties"] is not False
            reduced = self._validator.evolve(schema=keys, _resolver=resolver)
        self._cache[id(node)] = (whole, reduced)
        return whole, reduced

    def _descend(
        self,
        node: Any,
        resolver: Any,
        instance: Any,
        prefix: tuple[Any, ...],
        paths: list[tuple[str, ...]],
        hops: int,
        keys_changed: bool,
        plan: list[tuple[tuple[Any, ...], Any]] | None = None,
    ) -> list[tuple[tuple[Any, ...], Any]]:
        """The errors along ``paths`` (rules in :meth:`changed_violations`); with ``plan``,
        records the (prefix, validator) pairs it would run instead of running them."""
        while isinstance(node, dict) and "$ref" in node:  # draft-07: $ref replaces its siblings
            hops += 1
            if hops > 200:
                raise RecursionError
            cached = self._refs.get(id(node))
            if cached is None or cached[0] is not node:
                resolved = resolver.lookup(node["$ref"])
                cached = self._refs[id(node)] = (node, resolved.contents, resolved.resolver)
            node, resolver = cached[1], cached[2]
        whole, reduced = self._validators_for(node, resolver)
        separable = isinstance(node, dict) and isinstance(instance, dict) and _SEPARABLE.issuperset(node)
        if not separable or any(not p for p in paths):
            if plan is not None:
                plan.append((prefix, whole))
                return []
            return [(prefix, e) for e in whole.iter_errors(instance)]
        # the key-set checks: only when a name comes or goes (values alone leave them as they were)
        out = [(prefix, e) for e in reduced.iter_errors(instance)] if keys_changed else []
        children: dict[str, list[tuple[str, ...]]] = {}
        for p in paths:
            children.setdefault(p[0], []).append(p[1:])
        props = node.get("properties", {})
        patterns = node.get("patternProperties", {})
        for key, rest in children.items():
            if key not in instance:
                continue  # deleted: the key-set check covers it
            subs = [props[key]] if key in props else []
            subs += [sub for pattern, sub in patterns.items() if re.search(pattern, key)]
            extra = node.get("additionalProperties")
            if not subs and isinstance(extra, dict):
                subs = [extra]
            for sub in subs:
                out += self._descend(
                    sub, resolver, instance[key], (*prefix, key), rest, hops, keys_changed, plan
                )
        return out

    def document(self, values: Mapping[str, ParameterValue]) -> dict[str, Any]:
        """``values`` as the parameter file check-jsonschema would read: the envelope, nested."""
        return {self.node_key: {PARAMS_KEY: nest(values)}}

    def node_validator(
        self,
    ) -> Callable[
        [Mapping[str, ParameterValue], Mapping[str, ParameterValue | None]], tuple[str, str] | None
    ]:
        """The table's whole-node validator: the first violation, blamed on the touched name
        it concerns (a name at or under its path), else on none of them."""

        trusted = [False]  # the state last accepted was checked whole: later checks are incremental
        mirror = _Mirror()

        def check(
            values: Mapping[str, ParameterValue], before: Mapping[str, ParameterValue | None]
        ) -> tuple[str, str] | None:
            names = list(before)
            try:
                if trusted[0]:
                    found = self.changed_violations(values, before, mirror)
                else:
                    found = self.violations(values)
                    trusted[0] = not found
            except ParamddsError as exc:
                return "", f"schema {self.file}: {exc.message}"
            if not found:
                return None
            v = found[0]
            blamed = next((n for n in names if concerns(v.path, n)), "")
            reason = f"{v.path}: {v.message}" if v.path else v.message
            return blamed, f"schema: {reason}"

        return check


def _at(document: Any, prefix: tuple[Any, ...]) -> Any:
    for key in prefix:
        document = document[key]
    return document


def _present(values: Mapping[str, ParameterValue | None], name: str) -> bool:
    value = values.get(name)
    return value is not None and value.type is not T.NOT_SET


def _nested_at(params: dict[str, Any], parts: list[str]) -> bool:
    node: Any = params
    for part in parts:
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True


def concerns(path: str, name: str) -> bool:
    """Whether a violation at ``path`` (``a.b``, ``a.b[1]``) concerns the parameter ``name``."""
    return (
        not path or name == path or name.startswith(path + ".") or path.startswith((name + ".", name + "["))
    )


def _order(error: Any, prefix: tuple[Any, ...] = ()) -> tuple[int, str]:
    parts = [*prefix, *error.absolute_path]
    return (len(parts), ".".join(str(p) for p in parts))


def _violation(error: Any, prefix: tuple[Any, ...] = ()) -> Violation:
    parts = [*prefix, *error.absolute_path]
    where = "$" + "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts)
    path_parts = (
        [str(p) if not isinstance(p, int) else f"[{p}]" for p in parts[2:]] if len(parts) >= 2 else []
    )
    dotted = ".".join(path_parts).replace(".[", "[")
    message = str(error.message)
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        known = error.schema.get("properties", {}) if isinstance(error.schema, dict) else {}
        extra = [k for k in error.instance if k not in known]
        if len(extra) == 1 and len(parts) >= 2:
            dotted = f"{dotted}.{extra[0]}" if dotted else str(extra[0])
    if error.context and error.validator in ("oneOf", "anyOf"):
        branches: dict[int, list[str]] = {}
        for sub in error.context:
            index = sub.schema_path[0] if sub.schema_path else 0
            branches.setdefault(int(index), []).append(str(sub.message))
        detail = "; ".join(f"branch {i + 1}: {', '.join(m)}" for i, m in sorted(branches.items()))
        message = f"{message} ({detail})"
    if len(message) > MAX_TEXT:
        message = message[:MAX_TEXT] + "…"
    return Violation(dotted, message, where)


def _unresolvable(file: str, exc: Exception) -> FileFormatError:
    ref = getattr(exc, "ref", "")
    cause = exc.__cause__
    if isinstance(cause, FileFormatError):
        return cause
    return format_error(file, "", f"$ref {ref!r} cannot be resolved: {brief(exc)}")


def to_json(value: ParameterValue) -> Any:
    """A parameter value as JSON data (NOT_SET: None)."""
    v = value.value
    if isinstance(v, (tuple, list, bytes)):
        return list(v)
    return v


class _Mirror:
    """The nested document of the values last checked, patched for what changed since."""

    def __init__(self) -> None:
        self.values: dict[str, ParameterValue] = {}
        self.params: dict[str, Any] | None = None
        # name -> the (prefix, validator) a change of its value alone runs
        self.plans: dict[str, list[tuple[tuple[Any, ...], Any]]] = {}

    def update(self, values: Mapping[str, ParameterValue]) -> dict[str, Any]:
        old = self.values
        params = self.params
        if params is not None:
            changed = [n for n, v in values.items() if old.get(n) is not v]
            changed += [n for n in old if n not in values]
            if len(changed) * 4 > len(values) or not all(
                self._patch(params, n, values.get(n)) for n in changed
            ):
                params = None
        if params is None:
            params = nest(values)
        self.params, self.values = params, dict(values)
        return params

    @staticmethod
    def _patch(params: dict[str, Any], name: str, value: ParameterValue | None) -> bool:
        """Write one value in place; False when only a rebuild can (a name that is a prefix)."""
        parts = name.split(".")
        chain = [params]
        node = params
        for part in parts[:-1]:
            child = node.get(part)
            if child is None:
                if value is None or value.type is T.NOT_SET:
                    return True  # nothing there to delete
                child = node[part] = {}
            elif not isinstance(child, dict):
                return False
            chain.append(child)
            node = child
        leaf = parts[-1]
        if isinstance(node.get(leaf), dict):
            return False
        if value is None or value.type is T.NOT_SET:
            node.pop(leaf, None)
            for parent, part, child in zip(
                reversed(chain[:-1]), reversed(parts[:-1]), reversed(chain[1:]), strict=True
            ):
                if child:
                    break
                del parent[part]  # nest() writes no empty group
        else:
            node[leaf] = to_json(value)
        return True


def nest(values: Mapping[str, ParameterValue]) -> dict[str, Any]:
    """Dotted names as nested objects; unset values are left out. A name that is both a value
    and a prefix keeps the longer names as dotted keys (as a dump writes them)."""
    out: dict[str, Any] = {}
    for name in sorted(values):
        value = values[name]
        if value.type is T.NOT_SET:
            continue
        parts = name.split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.get(part)
            if child is None:
                child = node[part] = {}
            elif not isinstance(child, dict):
                node[".".join(parts[i:])] = to_json(value)
                break
            node = child
        else:
            node[parts[-1]] = to_json(value)
    return out
