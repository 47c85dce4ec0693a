"""Drives the pure core through one conformance case and reports how it disagrees with upstream.

A :class:`Case` is data written by us from an upstream test: where it comes from
(``source``: repository, file, test), what it feeds the core (``kind`` and ``input``)
and what upstream asserts (``expect``). :func:`run` returns ``None`` when the core
agrees, or one line saying what differed. A case marked ``deliberate`` is one where
we differ on purpose: it names the sentence of the "Fixed" list in docs/semantics.md that says
why, and ``ours`` is what we do instead (checked the same way, so a deliberate
difference is still pinned, never skipped).

Kinds and their data:

``yaml``
    input ``(text, node)``: a ROS 2 parameter file and the node it is loaded for.
    expect ``{name: (type_label, value)}`` for every parameter the node gets, or
    ``ERROR`` when the file is refused.
``range``
    input ``{"type": label, "range": (from, to, step), "value": x}``: a descriptor
    with one range and a set of ``x``. expect ``True`` (accepted) or ``False``.
``table``
    input ``{"options": {...}, "overrides": {...}}``; expect a list of steps, each
    ``(op, *args, outcome)`` run in order on one table (see :func:`_step`).
``spec``
    input spec text (the body under the root namespace); expect ``ERROR`` or
    ``{"names": [...], "ranges": {name: (from, to)}, "accept": [(name, value)],
    "refuse": [(name, value)], "overrides": {...}, "config": (ros_file_text, node),
    "declare_error": code}`` (the values of ``config`` are overrides; ``declare_error``:
    the file or the declaration must fail with that error code).
``list``
    input ``(names, prefixes, depth)``; expect ``(names, prefixes)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from paramdds.core.listing import list_names
from paramdds.core.table import ParameterTable
from paramdds.core.values import NOT_SET, Parameter, ParameterType, ParameterValue
from paramdds.errors import ParamddsError
from paramdds.formats.ros import load_ros_params_str, load_ros_text_full
from paramdds.formats.spec import declare_spec, load_spec_str

ERROR = "ERROR"
TYPES = {t.label: t for t in ParameterType}


@dataclass(frozen=True)
class Case:
    id: str
    source: str  # "repository file: test name"
    kind: str
    input: Any
    expect: Any
    deliberate: str = ""  # a sentence of docs/semantics.md's "Fixed" list when we differ on purpose
    ours: Any = None  # what we do instead, for a deliberate difference
    note: str = ""  # e.g. "rclcpp and rclpy differ; we follow rclcpp"


def run(case: Case) -> str | None:
    """None when the core does what the case expects; else what happened instead."""
    expected = case.ours if case.deliberate else case.expect
    runner = {"yaml": _yaml, "range": _range, "table": _table, "spec": _spec, "list": _list}[case.kind]
    return runner(case.input, expected)


@dataclass(frozen=True)
class Typed:
    """A value with its type spelled out, for what Python cannot type alone (an empty list)."""

    label: str
    value: object


def value(obj: object, label: str | None = None) -> ParameterValue:
    if isinstance(obj, Typed):
        return ParameterValue.of(TYPES[obj.label], obj.value)
    if label is not None:
        return ParameterValue.of(TYPES[label], obj)
    return ParameterValue.from_python(obj)


def _same(got: ParameterValue, label: str, want: object) -> bool:
    if got.type is not TYPES[label]:
        return False
    if isinstance(want, float) and math.isnan(want):
        return isinstance(got.value, float) and math.isnan(got.value)
    if isinstance(want, list):
        items = got.value
        assert isinstance(items, (tuple, bytes))
        return len(items) == len(want) and all(
            (isinstance(w, float) and math.isnan(w) and isinstance(g, float) and math.isnan(g))
            or (g == w and type(g) is type(w))
            for g, w in zip(items, want, strict=True)
        )
    return got.value == want and type(got.value) is type(want)


def _yaml(data: tuple[str, str], expected: object) -> str | None:
    text, node = data
    try:
        loaded = load_ros_text_full(text, node, source="case.yaml")
    except ParamddsError as exc:
        return None if expected == ERROR else f"refused the file: {exc}"
    if expected == ERROR:
        return f"accepted the file (gave {[n for n, _, _ in loaded]})"
    assert isinstance(expected, dict)
    got = {n: v for n, v, _ in loaded}
    if set(got) != set(expected):
        return f"names {sorted(got)} instead of {sorted(expected)}"
    for name, (label, want) in expected.items():
        if not _same(got[name], label, want):
            return f"{name} = {got[name].type.label} {got[name].value!r}, upstream {label} {want!r}"
    return None


def _range(data: dict[str, Any], expected: object) -> str | None:
    ptype = TYPES[data["type"]]
    lo, hi, step = data["range"]
    desc = ParameterDescriptor(
        "p",
        ptype,
        integer_range=IntegerRange(lo, hi, step) if ptype is ParameterType.INTEGER else None,
        floating_point_range=FloatingPointRange(lo, hi, step) if ptype is ParameterType.DOUBLE else None,
    )
    table = ParameterTable("n")
    try:
        table.declare("p", data.get("default", lo), desc)
    except ParamddsError as exc:
        return f"refused the declaration: {exc}"
    ok = table.set([Parameter("p", value(data["value"], data["type"]))]).results[0].successful
    return None if ok == expected else f"set {data['value']!r}: {'accepted' if ok else 'refused'}"


def _descriptor(name: str, spec: dict[str, Any]) -> ParameterDescriptor:
    kw = dict(spec)
    if "type" in kw:
        kw["type"] = TYPES[kw["type"]]
    if "integer_range" in kw:
        kw["integer_range"] = IntegerRange(*kw["integer_range"])
    if "floating_point_range" in kw:
        kw["floating_point_range"] = FloatingPointRange(*kw["floating_point_range"])
    return ParameterDescriptor(name, **kw)


def _table(data: dict[str, Any], steps: Sequence[tuple[Any, ...]]) -> str | None:
    overrides = {k: value(v) for k, v in data.get("overrides", {}).items()}
    table = ParameterTable("n", overrides=overrides, **data.get("options", {}))
    for i, step in enumerate(steps):
        problem = _step(table, step)
        if problem is not None:
            return f"step {i} {step[:-1]}: {problem}"
    return None


def _outcome(fn: Any) -> tuple[str, Any]:
    try:
        return "ok", fn()
    except ParamddsError as exc:
        return exc.code.value, None


def _step(table: ParameterTable, step: tuple[Any, ...]) -> str | None:
    """One step: ``(op, *args, outcome)``; outcome ``"ok"`` or an error code, or data for reads.

    ops: ``declare name value [descriptor-fields]``, ``set name value`` (outcome True/False:
    successful), ``set_many [(name, value)] [True/False…]``, ``atomic [(name, value)] True/False``,
    ``get name (label, value) | code``, ``has name bool``, ``type name label``,
    ``describe name {field: value}``, ``undeclare name outcome``, ``get_types [names] [labels]``,
    ``declare_ignoring_override name value outcome``,
    ``list prefixes depth (names, prefixes)``.
    """
    op, *args, want = step
    if op == "declare":
        name, default, *rest = args
        desc = _descriptor(name, rest[0]) if rest else None
        default_value = NOT_SET if default is None else value(default)
        got, _ = _outcome(lambda: table.declare(name, default_value, desc))
        return None if got == want else f"{got}, upstream {want}"
    if op == "declare_ignoring_override":
        name, default = args
        got, _ = _outcome(lambda: table.declare(name, value(default), ignore_override=True))
        return None if got == want else f"{got}, upstream {want}"
    if op == "get_types":
        (names,) = args
        labels = [t.label for t in table.get_types(names)]
        return None if labels == want else f"types {labels}, upstream {want}"
    if op == "set":
        name, v = args
        ok = table.set([Parameter(name, NOT_SET if v is None else value(v))]).results[0].successful
        return None if ok == want else f"{'accepted' if ok else 'refused'}, upstream the opposite"
    if op == "set_many":
        (pairs,) = args
        results = table.set([Parameter(n, NOT_SET if v is None else value(v)) for n, v in pairs]).results
        oks = [r.successful for r in results]
        return None if oks == want else f"{oks}, upstream {want}"
    if op == "atomic":
        (pairs,) = args
        results = table.set_atomically([Parameter(n, NOT_SET if v is None else value(v)) for n, v in pairs])
        ok = all(r.successful for r in results.results)
        return None if ok == want else f"{'applied' if ok else 'refused'}, upstream the opposite"
    if op == "get":
        (name,) = args
        got, v = _outcome(lambda: table.get(name))
        if isinstance(want, str):
            return None if got == want else f"{got}, upstream {want}"
        if got != "ok" or not _same(v, *want):
            return f"{got} {v!r}, upstream {want}"
        return None
    if op == "has":
        (name,) = args
        return None if table.has(name) == want else f"has={table.has(name)}"
    if op == "type":
        (name,) = args
        (t,) = table.get_types([name])
        return None if t is TYPES[want] else f"type {t.label}, upstream {want}"
    if op == "describe":
        (name,) = args
        got, desc = _outcome(lambda: table.describe_one(name))
        if isinstance(want, str):
            return None if got == want else f"{got}, upstream {want}"
        for field, w in want.items():
            v = getattr(desc, field)
            v = v.label if isinstance(v, ParameterType) else v
            if v != w:
                return f"descriptor {field} = {v!r}, upstream {w!r}"
        return None
    if op == "undeclare":
        (name,) = args
        got, _ = _outcome(lambda: table.undeclare(name))
        return None if got == want else f"{got}, upstream {want}"
    if op == "list":
        prefixes, depth = args
        result = table.list(prefixes, depth)
        got_list = (sorted(result.names), sorted(result.prefixes))
        return None if got_list == (sorted(want[0]), sorted(want[1])) else f"{got_list}, upstream {want}"
    raise AssertionError(f"unknown step {op!r}")


def _spec(text: str, expected: object) -> str | None:
    source = "root:\n" + "".join(f"  {line}\n" for line in text.splitlines())
    try:
        spec = load_spec_str(source, source="case_spec.yaml")
    except ParamddsError as exc:
        return None if expected == ERROR else f"refused the spec: {exc}"
    if expected == ERROR:
        return f"accepted the spec ({[e.name for e in spec]})"
    assert isinstance(expected, dict)
    overrides = {k: value(v) for k, v in expected.get("overrides", {}).items()}
    if "config" in expected:  # a ROS 2 parameter file and the node it configures
        config, node = expected["config"]
        try:
            overrides.update(load_ros_params_str(config, node, source="case_config.yaml"))
        except ParamddsError as exc:
            return None if expected.get("declare_error") == exc.code.value else f"refused the file: {exc}"
    table = ParameterTable("n", overrides=overrides)
    try:
        declare_spec(table, spec)
    except ParamddsError as exc:
        if expected.get("declare_error") == exc.code.value:
            return None
        return f"refused the declaration: {exc}"
    if "declare_error" in expected:
        return f"declared it, upstream reports an error ({expected['declare_error']})"
    if "names" in expected and table.names() != sorted(expected["names"]):
        return f"names {table.names()}, upstream {sorted(expected['names'])}"
    for name, want in expected.get("values", {}).items():
        got = table.get(name)
        if not _same(got, *want):
            return f"{name} = {got.type.label} {got.value!r}, upstream {want}"
    for name, want in expected.get("ranges", {}).items():
        desc = table.describe_one(name)
        r = desc.integer_range or desc.floating_point_range
        got_r = None if r is None else (r.from_value, r.to_value)
        if got_r != want:
            return f"{name} range {got_r}, upstream {want}"
    for name, v in expected.get("accept", []):
        result = table.set([Parameter(name, value(v))]).results[0]
        if not result.successful:
            return f"refused {name}={v!r}: {result.reason}"
    for name, v in expected.get("refuse", []):
        if table.set([Parameter(name, value(v))]).results[0].successful:
            return f"accepted {name}={v!r}"
    return None


def _list(data: tuple[list[str], list[str], int], expected: tuple[list[str], list[str]]) -> str | None:
    names, prefixes, depth = data
    got_names, got_prefixes = list_names(sorted(names), prefixes, depth)
    got = (sorted(got_names), sorted(got_prefixes))
    want = (sorted(expected[0]), sorted(expected[1]))
    return None if got == want else f"{got}, upstream {want}"
