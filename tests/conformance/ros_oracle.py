"""Real ROS 2 as the oracle: the same operations through an rclpy ``Node`` and our table.

ROS 2 (rclpy, rcl and its C YAML parser, from the PyPI ``ros-*`` wheels: the ``ros2``
extra) runs in this process with discovery off (``ROS_AUTOMATIC_DISCOVERY_RANGE=OFF``),
its logs in a temporary directory and a random ``ROS_DOMAIN_ID``; see :func:`ros_session`.

Each side of an operation ends in an :class:`Outcome`: ``("ok", payload)`` or
``("fail", kind)``. A *kind* is one of ROS 2's own fault kinds (the exception rclpy
raises, or the family of the reason a ``SetParametersResult`` gives); our
:class:`~paramdds.errors.ErrorCode` s map to them through :data:`OUR_KINDS`, never
through message text. Two outcomes agree when both succeed with equal payloads, or
both fail with compatible kinds.

Comparison stops at the first disagreement of a sequence: it is either explained by
an entry of :data:`DIFFERENCES` (a sentence of the "Fixed" list in docs/semantics.md,
or a place where rclpy departs from rclcpp, with the rclcpp source that decides), or
it is a failure that prints the sequence so far as a reproducer.
"""

from __future__ import annotations

import math
import os
import random
import tempfile
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.values import INT64_MAX, INT64_MIN, NOT_SET, Parameter, ParameterType, ParameterValue
from paramdds.errors import ErrorCode, ParamddsError

T = ParameterType
AUTOMATIC = ("use_sim_time", "start_type_description_service")  # every rclpy node declares them


def ros_missing() -> str | None:
    """Why real ROS 2 cannot be used here, or None when it can."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # rclpy's dependencies import deprecated modules
            import rclpy
            import rclpy.node  # noqa: F401
            from rcl_interfaces.msg import ParameterDescriptor  # noqa: F401
    except ImportError as exc:
        return (
            f"real ROS 2 is not installed ({exc}); pip install -e '.[ros2]' (wheels exist for "
            "CPython 3.10-3.12 on Linux x86_64)"
        )
    return None


@contextmanager
def ros_session() -> Iterator[Any]:
    """An rclpy Context isolated from any other ROS process; yields it."""
    saved = {k: os.environ.get(k) for k in ("ROS_LOG_DIR", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")}
    with tempfile.TemporaryDirectory(prefix="paramdds-ros-") as logs:
        os.environ["ROS_LOG_DIR"] = logs
        os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"
        os.environ["ROS_DOMAIN_ID"] = str(random.randint(100, 200))
        import rclpy
        from rclpy.context import Context

        context = Context()
        rclpy.init(args=[], context=context)
        try:
            yield context
        finally:
            rclpy.shutdown(context=context)
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


# --- outcomes -------------------------------------------------------------------------------

Outcome = tuple[str, Any]

# ROS 2's fault kinds, and which of ours stand for each.
OUR_KINDS: dict[ErrorCode, frozenset[str]] = {
    ErrorCode.NOT_FOUND: frozenset({"NOT_DECLARED"}),
    ErrorCode.ALREADY_DECLARED: frozenset({"ALREADY_DECLARED"}),
    ErrorCode.TYPE_MISMATCH: frozenset({"INVALID_TYPE"}),
    ErrorCode.OUT_OF_RANGE: frozenset({"INVALID_VALUE"}),
    ErrorCode.INVALID_VALUE: frozenset({"INVALID_VALUE", "INVALID_ARGUMENT", "UNINITIALIZED"}),
    ErrorCode.READ_ONLY: frozenset({"READ_ONLY"}),
    ErrorCode.INVALID_NAME: frozenset({"INVALID_NAME"}),
}

# The families of reasons rclpy puts in a failed SetParametersResult (node.py, _apply_descriptor
# and friends): the reason is the only carrier of the fault there.
_REASONS: tuple[tuple[str, str], ...] = (
    ("Trying to set a read-only parameter", "READ_ONLY"),
    ("Static parameter cannot be undeclared", "INVALID_TYPE"),
    ("Wrong parameter type", "INVALID_TYPE"),
    ("out of range", "INVALID_VALUE"),
    ("is not a valid step", "INVALID_VALUE"),
    ("not close enough to a valid step", "INVALID_VALUE"),
)


def _reason_kind(reason: str) -> str:
    for needle, kind in _REASONS:
        if needle in reason:
            return kind
    raise AssertionError(f"rclpy gave a reason this harness does not classify: {reason!r}")


def _exception_kind(exc: BaseException) -> str:
    from rclpy import exceptions as rx

    table: tuple[tuple[type[BaseException], str], ...] = (
        (rx.ParameterNotDeclaredException, "NOT_DECLARED"),
        (rx.ParameterAlreadyDeclaredException, "ALREADY_DECLARED"),
        (rx.InvalidParameterTypeException, "INVALID_TYPE"),
        (rx.InvalidParameterValueException, "INVALID_VALUE"),
        (rx.ParameterImmutableException, "READ_ONLY"),
        (rx.ParameterUninitializedException, "UNINITIALIZED"),
        (rx.InvalidParameterException, "INVALID_NAME"),
        ((ValueError, TypeError), "INVALID_ARGUMENT"),  # type: ignore[arg-type]
    )
    for cls, kind in table:
        if isinstance(exc, cls):
            return kind
    raise exc


def _ours(fn: Callable[[], Any]) -> Outcome:
    try:
        return "ok", fn()
    except ParamddsError as exc:
        return "fail", exc.code


def agree(ros: Outcome, ours: Outcome) -> bool:
    if ros[0] != ours[0]:
        return False
    if ros[0] == "fail":
        return ros[1] in OUR_KINDS.get(ours[1], frozenset())
    return same_payload(ros[1], ours[1])


def same_payload(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or a == b
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same_payload(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_payload(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b


# --- converting ------------------------------------------------------------------------------


def to_ros(name: str, v: ParameterValue) -> Any:
    from rclpy.parameter import Parameter as RosParameter

    return RosParameter(name, RosParameter.Type(int(v.type)), _py_for_ros(v))


def _py_for_ros(v: ParameterValue) -> Any:
    if v.type is T.BYTE_ARRAY:
        assert isinstance(v.value, bytes)
        return [bytes([b]) for b in v.value]
    if isinstance(v.value, tuple):
        return list(v.value)
    return v.value


def from_ros(p: Any) -> tuple[str, Any]:
    """An rclpy Parameter as ``(type label, plain value)``."""
    t = T(int(p.type_.value))
    value = p.value
    if t is T.BYTE_ARRAY:
        value = b"".join(value)
    elif t.is_array:
        value = tuple(value)
    return t.label, value


def ours_plain(v: ParameterValue) -> tuple[str, Any]:
    return v.type.label, v.value


def desc_to_ros(d: ParameterDescriptor) -> Any:
    from rcl_interfaces.msg import FloatingPointRange as RosFr
    from rcl_interfaces.msg import IntegerRange as RosIr
    from rcl_interfaces.msg import ParameterDescriptor as RosDesc

    out = RosDesc(
        name=d.name,
        type=int(d.type),
        description=d.description,
        additional_constraints=d.additional_constraints,
        read_only=d.read_only,
        dynamic_typing=d.dynamic_typing,
    )
    if d.integer_range is not None:
        r = d.integer_range
        out.integer_range = [RosIr(from_value=r.from_value, to_value=r.to_value, step=r.step)]
    if d.floating_point_range is not None:
        f = d.floating_point_range
        out.floating_point_range = [RosFr(from_value=f.from_value, to_value=f.to_value, step=f.step)]
    return out


def desc_plain_ros(d: Any) -> dict[str, Any]:
    ir = (
        (d.integer_range[0].from_value, d.integer_range[0].to_value, d.integer_range[0].step)
        if len(d.integer_range)
        else None
    )
    fr = d.floating_point_range
    fp = (fr[0].from_value, fr[0].to_value, fr[0].step) if len(fr) else None
    return {
        "type": T(d.type).label,
        "description": d.description,
        "additional_constraints": d.additional_constraints,
        "read_only": bool(d.read_only),
        "dynamic_typing": bool(d.dynamic_typing),
        "integer_range": ir,
        "floating_point_range": fp,
    }


def desc_plain_ours(d: ParameterDescriptor) -> dict[str, Any]:
    ir = d.integer_range
    fr = d.floating_point_range
    return {
        "type": d.type.label,
        "description": d.description,
        "additional_constraints": d.additional_constraints,
        "read_only": d.read_only,
        "dynamic_typing": d.dynamic_typing,
        "integer_range": None if ir is None else (ir.from_value, ir.to_value, ir.step),
        "floating_point_range": None if fr is None else (fr.from_value, fr.to_value, fr.step),
    }


# --- operations ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Op:
    """One operation: ``kind`` and its arguments (plain data, so a failure prints a reproducer)."""

    kind: str  # declare, set, atomic, undeclare, get, describe, types, list
    args: tuple[Any, ...]

    def __repr__(self) -> str:
        return f"{self.kind}{self.args!r}"


@dataclass
class Sides:
    """One rclpy node and one table, started alike."""

    node: Any
    table: ParameterTable
    allow_undeclared: bool
    log: list[Op] = field(default_factory=list)
    before: dict[str, ParameterDescriptor] = field(default_factory=dict)  # our descriptors before the op


def make_sides(
    context: Any, index: int, allow_undeclared: bool, overrides: dict[str, ParameterValue]
) -> Sides:
    from rclpy.node import Node

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a node's first creation imports deprecated modules
        node = Node(
            f"oracle{index}",
            context=context,
            allow_undeclared_parameters=allow_undeclared,
            parameter_overrides=[to_ros(n, v) for n, v in overrides.items()],
            start_parameter_services=False,
            enable_rosout=False,
        )
    table = ParameterTable("oracle", allow_undeclared=allow_undeclared, overrides=overrides)
    return Sides(node, table, allow_undeclared)


def run_ros(s: Sides, op: Op) -> Outcome:
    from rclpy import exceptions as rx

    n = s.node
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rclpy warns about deprecated forms we exercise on purpose
        try:
            if op.kind == "declare":
                name, default, desc, ignore = op.args
                # always a descriptor: rclpy reads a bare declare_parameter(name) as its deprecated
                # "dynamically typed" form, which rclcpp no longer has
                rdesc = desc_to_ros(desc if desc is not None else ParameterDescriptor(name))
                if default.type is T.NOT_SET and desc is not None and desc.type is not T.NOT_SET:
                    from rclpy.parameter import Parameter as RosParameter

                    p = n.declare_parameter(name, RosParameter.Type(int(desc.type)), rdesc, ignore)
                else:
                    p = n.declare_parameter(name, _py_for_ros(default), rdesc, ignore)
                return "ok", from_ros(p)
            if op.kind == "set":
                out = []
                for name, v in op.args[0]:
                    try:
                        r = n.set_parameters_atomically([to_ros(name, v)])
                        out.append(("ok", None) if r.successful else ("fail", _reason_kind(r.reason)))
                    except rx.ParameterNotDeclaredException:
                        out.append(("fail", "NOT_DECLARED"))
                return "ok", out
            if op.kind == "atomic":
                r = n.set_parameters_atomically([to_ros(name, v) for name, v in op.args[0]])
                return ("ok", None) if r.successful else ("fail", _reason_kind(r.reason))
            if op.kind == "undeclare":
                n.undeclare_parameter(op.args[0])
                return "ok", None
            if op.kind == "get":
                return "ok", from_ros(n.get_parameter(op.args[0]))
            if op.kind == "describe":
                return "ok", desc_plain_ros(n.describe_parameter(op.args[0]))
            if op.kind == "types":
                return "ok", [T(int(t)).label for t in n.get_parameter_types(list(op.args[0]))]
            if op.kind == "list":
                prefixes, depth = op.args
                r = n.list_parameters(list(prefixes), depth)
                names = sorted(x for x in r.names if x not in AUTOMATIC)
                return "ok", (names, sorted(set(r.prefixes)))
        except Exception as exc:
            return "fail", _exception_kind(exc)
    raise AssertionError(f"unknown op {op.kind}")


def run_ours(s: Sides, op: Op) -> Outcome:
    t = s.table
    if op.kind == "declare":
        name, default, desc, ignore = op.args
        return _ours(lambda: ours_plain(t.declare(name, default, desc, ignore_override=ignore)))
    if op.kind in ("set", "atomic"):
        params = [Parameter(name, v) for name, v in op.args[0]]
        if op.kind == "set":
            results = t.set(params).results
            return "ok", [("ok", None) if r.successful else ("fail", r.code) for r in results]
        results = t.set_atomically(params).results
        if all(r.successful for r in results):
            return "ok", None
        codes = [r.code for r in results]
        # the parameter at fault carries its own code; the others say INVALID_VALUE ("not applied")
        return "fail", next((c for c in codes if c is not ErrorCode.INVALID_VALUE), ErrorCode.INVALID_VALUE)
    if op.kind == "undeclare":
        return _ours(lambda: t.undeclare(op.args[0]))
    if op.kind == "get":
        return _ours(lambda: ours_plain(t.get(op.args[0])))
    if op.kind == "describe":
        return _ours(lambda: desc_plain_ours(t.describe_one(op.args[0])))
    if op.kind == "types":
        return "ok", [x.label for x in t.get_types(list(op.args[0]))]
    if op.kind == "list":
        prefixes, depth = op.args
        r = t.list(list(prefixes), depth)
        return "ok", (sorted(r.names), sorted(set(r.prefixes)))
    raise AssertionError(f"unknown op {op.kind}")


def op_agrees(op: Op, ros: Outcome, ours: Outcome) -> bool:
    if op.kind == "set" and ros[0] == ours[0] == "ok":
        return len(ros[1]) == len(ours[1]) and all(agree(a, b) for a, b in zip(ros[1], ours[1], strict=True))
    return agree(ros, ours)


def state_ros(s: Sides) -> dict[str, Any]:
    n = s.node
    return {
        name: (from_ros(p), desc_plain_ros(n._descriptors[name]))
        for name, p in n._parameters.items()
        if name not in AUTOMATIC
    }


def state_ours(s: Sides) -> dict[str, Any]:
    return {name: (ours_plain(v), desc_plain_ours(d)) for name, v, d in s.table.snapshot()}


# --- generating ------------------------------------------------------------------------------

NAMES = ("a", "b", "a.b", "a.b.c", "a.c", "x.y", "n")
VALUES: dict[ParameterType, tuple[object, ...]] = {
    T.BOOL: (True, False),
    T.INTEGER: (0, 1, -1, 5, 7, 10, 100, INT64_MAX, INT64_MIN),
    T.DOUBLE: (0.0, 0.5, 1.5, -2.5, 10.0, 3.3, math.nan, math.inf, -math.inf, 1e-300),
    T.STRING: ("", "abc", "héllo ✓", "日本"),
    T.BYTE_ARRAY: (b"", b"\x00\xff", b"abc"),
    T.BOOL_ARRAY: ((), (True,), (False, True)),
    T.INTEGER_ARRAY: ((), (1, 2), (INT64_MAX, INT64_MIN)),
    T.DOUBLE_ARRAY: ((), (1.0,), (math.nan, -0.0)),
    T.STRING_ARRAY: ((), ("a",), ("ü", "")),
}


def random_value(
    rng: random.Random, ptype: ParameterType | None = None, *, not_set: float = 0.08
) -> ParameterValue:
    if ptype is None:
        if rng.random() < not_set:
            return NOT_SET
        ptype = rng.choice([t for t in T if t is not T.NOT_SET])
    if ptype is T.NOT_SET:
        return NOT_SET
    return ParameterValue.of(ptype, rng.choice(VALUES[ptype]))


def random_descriptor(rng: random.Random, name: str, vtype: ParameterType) -> ParameterDescriptor | None:
    if rng.random() < 0.3:
        return None
    dynamic = rng.random() < 0.25
    dtype = T.NOT_SET
    if rng.random() < 0.3:
        dtype = vtype if rng.random() < 0.8 else rng.choice(list(T))
    ir = fr = None
    if rng.random() < 0.3:
        lo = rng.choice((-10, 0, 1, 5))
        ir = IntegerRange(lo, lo + rng.choice((0, 4, 10, 20)), rng.choice((0, 0, 1, 2, 5)))
    if rng.random() < 0.3:
        lo_f = rng.choice((-10.0, 0.0, 0.5))
        fr = FloatingPointRange(lo_f, lo_f + rng.choice((0.0, 1.0, 10.0)), rng.choice((0.0, 0.0, 0.5, 0.1)))
        if rng.random() < 0.15:  # open and broken ends
            fr = rng.choice(
                (
                    FloatingPointRange(-math.inf, 0.0, 0.0),
                    FloatingPointRange(0.0, math.inf, 0.0),
                    FloatingPointRange(-math.inf, math.inf, 0.0),
                    FloatingPointRange(math.nan, 1.0, 0.0),
                )
            )
    return ParameterDescriptor(
        name,
        dtype,
        description=rng.choice(("", "speed", "ünïcode")),
        additional_constraints=rng.choice(("", "> 0")),
        read_only=rng.random() < 0.15,
        dynamic_typing=dynamic,
        integer_range=ir,
        floating_point_range=fr,
    )


def random_op(rng: random.Random, declared: list[str]) -> Op:
    def name() -> str:
        if declared and rng.random() < 0.75:
            return rng.choice(declared)
        return rng.choice(NAMES)

    def pair(nm: str) -> tuple[str, ParameterValue]:
        return nm, random_value(rng)

    r = rng.random()
    if r < 0.3:
        nm = rng.choice(NAMES)
        default = random_value(rng, not_set=0.15)
        while default.type.is_array and not default.value:
            default = random_value(rng, not_set=0.15)  # rclpy cannot declare a typed empty list
        return Op("declare", (nm, default, random_descriptor(rng, nm, default.type), rng.random() < 0.1))
    if r < 0.5:
        return Op("set", ([pair(name()) for _ in range(rng.randint(1, 3))],))
    if r < 0.65:
        return Op("atomic", ([pair(name()) for _ in range(rng.randint(1, 3))],))
    if r < 0.7:
        return Op("undeclare", (name(),))
    if r < 0.8:
        return Op("get", (name(),))
    if r < 0.87:
        return Op("describe", (name(),))
    if r < 0.92:
        return Op("types", ([name() for _ in range(rng.randint(1, 2))],))
    prefixes = rng.choice(((), ("a",), ("a", "x"), ("a.b",), ("zz",)))
    return Op("list", (prefixes, rng.choice((0, 0, 1, 2, 3))))


def random_start(rng: random.Random) -> tuple[bool, dict[str, ParameterValue]]:
    allow = rng.random() < 0.4
    overrides = {}
    for nm in NAMES:
        if rng.random() < 0.15:
            v = random_value(rng, not_set=0.0)
            if not (v.type.is_array and not v.value):  # rclpy retypes an empty list override
                overrides[nm] = v
    return allow, overrides


# --- running a sequence ----------------------------------------------------------------------


@dataclass
class Verdict:
    """How one sequence went: the listed differences it hit, or an unexplained disagreement.

    A sequence goes on after a listed difference as long as both tables still hold the same
    parameters (a read that differs changes nothing); it stops where they diverge.
    """

    ops: int = 0
    differences: list[str] = field(default_factory=list)  # ids of the DIFFERENCES entries hit
    problem: str | None = None  # an unexplained disagreement, with its reproducer
    diverged: bool = False


def run_sequence(context: Any, index: int, seed: int, length: int) -> Verdict:
    rng = random.Random(seed)
    allow, overrides = random_start(rng)
    s = make_sides(context, index, allow, overrides)
    verdict = Verdict()
    try:
        for _ in range(length):
            op = random_op(rng, list(s.table.names()))
            s.before = {name: d for name, _, d in s.table.snapshot()}
            ros, ours = run_ros(s, op), run_ours(s, op)
            s.log.append(op)
            verdict.ops += 1
            explained = op_agrees(op, ros, ours) or _explain(s, op, ros, ours, seed, verdict)
            if verdict.problem is not None:
                return verdict
            rs, os_ = state_ros(s), state_ours(s)
            if not same_payload(rs, os_):
                if explained is True and op_agrees(op, ros, ours):
                    _explain(s, op, ("state", rs), ("state", os_), seed, verdict)
                verdict.diverged = True
                return verdict
        return verdict
    finally:
        s.node.destroy_node()


def _explain(s: Sides, op: Op, ros: Outcome, ours: Outcome, seed: int, verdict: Verdict) -> bool:
    for diff in DIFFERENCES:
        if diff.applies(s, op, ros, ours):
            verdict.differences.append(diff.id)
            return True
    start = f"allow_undeclared={s.allow_undeclared}, overrides={s.table._overrides!r}"
    steps = "\n  ".join(repr(o) for o in s.log)
    verdict.problem = f"seed {seed}: ROS 2 {ros!r}, ours {ours!r} at the last op of\n  [{start}]\n  {steps}"
    return False


@dataclass(frozen=True)
class Difference:
    """A disagreement we keep: ``fixed`` quotes docs/semantics.md's Fixed list, or ``rclcpp``
    says where rclpy (our in-process oracle) departs from rclcpp, which we follow."""

    id: str
    applies: Callable[[Sides, Op, Outcome, Outcome], bool]
    fixed: str = ""
    rclcpp: str = ""


def _fails(o: Outcome, *kinds: object) -> bool:
    return o[0] == "fail" and o[1] in kinds


def _declared(s: Sides, name: str) -> bool:
    return name in s.before


def _set_items(
    op: Op, ros: Outcome, ours: Outcome
) -> list[tuple[tuple[str, ParameterValue], Outcome, Outcome]]:
    """For a ``set``: each parameter with both outcomes, where they disagree."""
    if op.kind != "set" or ros[0] != "ok" or ours[0] != "ok":
        return []
    return [(p, a, b) for p, a, b in zip(op.args[0], ros[1], ours[1], strict=True) if not agree(a, b)]


def _declared_value(s: Sides, op: Op) -> ParameterValue:
    """The value a declare operation takes: the parameter file's override, unless the
    declaration ignores overrides, else its default."""
    name, default, _desc, ignore = op.args
    override = None if ignore else s.table.override(name)
    return override if override is not None else default


def _one_param_ops(
    op: Op, ros: Outcome, ours: Outcome
) -> list[tuple[tuple[str, ParameterValue], Outcome, Outcome]]:
    """The parameters a set or atomic set disagrees on (an atomic set: all of them)."""
    if op.kind == "set":
        return _set_items(op, ros, ours)
    if op.kind == "atomic":
        return [(p, ros, ours) for p in op.args[0]]
    return []


def _status_per_name(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    if op.kind in ("get", "describe") and not _declared(s, op.args[0]):
        return _fails(ours, ErrorCode.NOT_FOUND) and (ros[0] == "ok" or _fails(ros, "NOT_DECLARED"))
    if op.kind == "types":
        unknown = [not _declared(s, n) for n in op.args[0]]
        return any(unknown) and _fails(ros, "NOT_DECLARED") and ours[0] == "ok"
    return False


def _widened(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    """An integer (array) given for a double (array) parameter: ROS refuses the type, we widen."""

    def widening(name: str, v: ParameterValue) -> bool:
        entry = s.before[name] if _declared(s, name) else None
        pairs = {(T.INTEGER, T.DOUBLE), (T.INTEGER_ARRAY, T.DOUBLE_ARRAY)}
        return entry is not None and not entry.dynamic_typing and (v.type, entry.type) in pairs

    if op.kind == "declare":
        _name, default, desc, _ignore = op.args
        chosen = _declared_value(s, op)
        pairs = {(T.INTEGER, T.DOUBLE), (T.INTEGER_ARRAY, T.DOUBLE_ARRAY)}
        dtype = desc.type if desc is not None and default.type is T.NOT_SET else default.type
        return _fails(ros, "INVALID_TYPE") and (chosen.type, dtype) in pairs
    return any(widening(n, v) and _fails(a, "INVALID_TYPE") for (n, v), a, _ in _one_param_ops(op, ros, ours))


def _array_range(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    """A range given to an integer or double array bounds its elements here, nothing in ROS."""

    def ranged_array(v: ParameterValue, d: ParameterDescriptor | None) -> bool:
        if d is None:
            return False
        if v.type is T.INTEGER_ARRAY and d.integer_range is not None:
            return True
        return v.type is T.DOUBLE_ARRAY and d.floating_point_range is not None

    if op.kind == "declare":
        desc = op.args[2]
        chosen = _declared_value(s, op)
        return ros[0] == "ok" and _fails(ours, ErrorCode.OUT_OF_RANGE) and ranged_array(chosen, desc)
    return any(
        _fails(b, ErrorCode.OUT_OF_RANGE) and _declared(s, n) and ranged_array(v, s.before[n])
        for (n, v), _, b in _one_param_ops(op, ros, ours)
    )


def _untyped_declare(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    if op.kind != "declare":
        return False
    _, default, desc, _ = op.args
    untyped = default.type is T.NOT_SET and (
        desc is None or (desc.type is T.NOT_SET and not desc.dynamic_typing)
    )
    # rclcpp checks "already declared" before the type (rclpy the other way round)
    ours_kind = ErrorCode.ALREADY_DECLARED if _declared(s, op.args[0]) else ErrorCode.TYPE_MISMATCH
    return untyped and _fails(ros, "INVALID_ARGUMENT") and _fails(ours, ours_kind)


def _undeclare_static(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    if op.kind != "undeclare" or not _declared(s, op.args[0]):
        return False
    static = not s.before[op.args[0]].dynamic_typing
    return static and ros[0] == "ok" and _fails(ours, ErrorCode.TYPE_MISMATCH)


def _state_entries(ros: Outcome, ours: Outcome) -> list[tuple[str, Any, Any]] | None:
    if ros[0] != "state":
        return None
    a, b = ros[1], ours[1]
    return [(n, a.get(n), b.get(n)) for n in sorted(set(a) | set(b)) if not same_payload(a.get(n), b.get(n))]


def _implicit_declare(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    """After a set with undeclared parameters allowed, each entry that differs is one rclcpp
    declared without a value (rclpy: absent), or one whose dynamic descriptor's type follows
    its value (rclpy: not_set)."""
    if op.kind == "set":  # a later entry finds the valueless parameter rclpy deleted
        pairs = op.args[0]
        for (n, v0), a, b in _set_items(op, ros, ours)[:1]:
            earlier = [v for m, v in pairs[: pairs.index((n, v0))] if m == n]
            if _fails(a, "NOT_DECLARED") and b[0] == "ok" and any(v.type is T.NOT_SET for v in earlier):
                return True
    entries = _state_entries(ros, ours)
    if not entries:
        return False
    deleted = {n for n, v in op.args[0] if v.type is T.NOT_SET} if op.kind in ("set", "atomic") else set()
    for name, r, o in entries:
        if o is None or not o[1]["dynamic_typing"]:
            return False
        if r is None:
            # rclcpp keeps a valueless dynamic parameter that is set to NOT_SET: it undeclares only
            # 'it->second.value.get_type() != PARAMETER_NOT_SET' (rclpy deletes it)
            if not (name in deleted and o[0] == ("not_set", None)):
                return False
        elif (
            not same_payload(r[0], o[0]) or {**r[1], "type": o[1]["type"]} != o[1] or o[1]["type"] != o[0][0]
        ):
            return False
    return True


def _atomic_order(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    """rclcpp checks "declared" and "read-only" parameter by parameter, in request order; rclpy
    checks every name for "declared" first."""
    if op.kind != "atomic" or ros[0] != "fail" or not _fails(ours, ErrorCode.READ_ONLY):
        return False
    for name, _ in op.args[0]:
        if not _declared(s, name):
            if s.allow_undeclared:
                continue  # rclcpp declares it later; it is neither missing nor read-only
            return False
        if s.before[name].read_only:
            return True  # rclpy reports a later parameter's fault (its type, range or name)
    return False


def _atomic_twice(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    if op.kind != "atomic":
        return False
    names = [n for n, _ in op.args[0]]
    deleted_then_named = any(
        v.type is T.NOT_SET and n in names[i + 1 :] for i, (n, v) in enumerate(op.args[0])
    )
    return deleted_then_named


def _tiny_on_grid(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    """A double within 1e-6 of a step of a grid point: ROS 2's test is relative only."""

    def tiny(v: ParameterValue) -> bool:
        return v.type is T.DOUBLE and isinstance(v.value, float) and 0 < abs(v.value) < 1e-6

    if op.kind == "declare":
        return tiny(op.args[1]) and _fails(ros, "INVALID_VALUE") and ours[0] == "ok"
    return any(tiny(v) and _fails(a, "INVALID_VALUE") for (_, v), a, _ in _one_param_ops(op, ros, ours))


# the rclcpp source read for each "rclcpp" entry below (ros2/rclcpp at commit 00bf8fb)
_NODE_PARAMETERS_CPP = "ros2/rclcpp@00bf8fb rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp"


def _nan_bound(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    if op.kind != "declare" or op.args[2] is None or op.args[2].floating_point_range is None:
        return False
    r = op.args[2].floating_point_range
    nan = math.isnan(r.from_value) or math.isnan(r.to_value)
    return nan and _fails(ours, ErrorCode.INVALID_VALUE) and not _fails(ros, "ALREADY_DECLARED")


def _infinite_bound(s: Sides, op: Op, ros: Outcome, ours: Outcome) -> bool:
    """±inf at an infinite bound of its range: rclpy (and rclcpp, without a step) accept it."""

    def at_infinite_bound(v: ParameterValue, d: ParameterDescriptor | None) -> bool:
        r = d.floating_point_range if d is not None else None
        return (
            r is not None
            and v.type is T.DOUBLE
            and isinstance(v.value, float)
            and math.isinf(v.value)
            and v.value in (r.from_value, r.to_value)
        )

    if op.kind == "declare":
        desc = op.args[2]
        chosen = _declared_value(s, op)
        return ros[0] == "ok" and _fails(ours, ErrorCode.OUT_OF_RANGE) and at_infinite_bound(chosen, desc)
    return any(
        _fails(b, ErrorCode.OUT_OF_RANGE) and at_infinite_bound(v, s.before.get(n))
        for (n, v), _, b in _one_param_ops(op, ros, ours)
    )


DIFFERENCES: list[Difference] = [
    Difference(
        "nan-range-bound",
        _nan_bound,
        fixed="a floating-point range with a NaN bound is refused when declared",
    ),
    Difference(
        "infinite-bound",
        _infinite_bound,
        fixed="NaN and ±inf never pass a floating-point range, not even an infinite bound",
    ),
    Difference(
        "float-grid-tolerance",
        _tiny_on_grid,
        fixed="a double within 1e-6 of a step of a grid point is on the grid",
    ),
    Difference(
        "atomic-delete-then-name",
        _atomic_twice,
        fixed="in one atomic set each entry sees the ones before it, so a name deleted earlier in "
        "the request is undeclared for the entries after it",
    ),
    Difference(
        "implicit-declare",
        _implicit_declare,
        rclcpp=f"{_NODE_PARAMETERS_CPP}, set_parameters_atomically: an "
        "undeclared name (undeclared parameters allowed) is declared by __declare_parameter_common, "
        "which stores a NOT_SET value 'without a value' (rclpy stores nothing); and "
        "__set_parameters_atomically_common sets 'descriptor.type = parameters[i].get_type()' "
        "(rclpy leaves an implicitly declared parameter's type at not_set, or changes it before "
        "a check that then fails); set_parameters_atomically undeclares on NOT_SET only a parameter "
        "that has a value (rclpy deletes a valueless one too)",
    ),
    Difference(
        "atomic-check-order",
        _atomic_order,
        rclcpp=f"{_NODE_PARAMETERS_CPP}, set_parameters_atomically: "
        "'Check if any of the parameters are read-only, or if any parameters are not declared', "
        "one parameter at a time in request order (rclpy: _check_undeclared_parameters first)",
    ),
    Difference(
        "untyped-declare-kind",
        _untyped_declare,
        rclcpp=f"{_NODE_PARAMETERS_CPP}, declare_parameter_helper: "
        "InvalidParameterTypeException 'cannot declare a statically typed parameter with an "
        "uninitialized value' (rclpy raises ValueError)",
    ),
    Difference(
        "undeclare-static",
        _undeclare_static,
        rclcpp=f"{_NODE_PARAMETERS_CPP}, undeclare_parameter: "
        "InvalidParameterTypeException 'cannot undeclare a statically typed parameter' (rclpy "
        "undeclares it)",
    ),
    Difference(
        "status-per-name",
        _status_per_name,
        fixed="get and describe report a status per name instead of an empty reply",
    ),
    Difference(
        "int-widened",
        _widened,
        fixed="an integer for a double parameter is widened (`50` → `50.0`, rclcpp#979) unless strict",
    ),
    Difference(
        "array-range",
        _array_range,
        fixed="a range also bounds each element of an integer or double array",
    ),
]


# --- running sequences in a child process -----------------------------------------------------
#
# rclpy (Kilted, Fast DDS) occasionally dies of SIGSEGV inside Node.destroy_node() when many
# nodes come and go in one context (seen once in ~3,000 sequences under load; rclpy's own
# tracker has several such reports). That is ROS 2's crash, not a disagreement, but in the
# test process it would take the whole pytest run with it. So the sequences run in a child
# that prints one JSON verdict per line; a child killed by a signal is started again at the
# sequence it died in, and the crash is reported.


def main_sequences(start: int, stop: int, length: int) -> None:
    """The child: run sequences [start, stop) and print one JSON verdict per line."""
    import json
    import sys

    crash_at = int(os.environ.get("PARAMDDS_ORACLE_CRASH_AT", "-1"))  # the runner's own test
    with ros_session() as context:
        for i in range(start, stop):
            if i == crash_at and start < crash_at:
                os.kill(os.getpid(), 11)  # SIGSEGV, as rclpy's crash does
            v = run_sequence(context, i, seed=i, length=length)
            line = {"i": i, "ops": v.ops, "differences": v.differences, "problem": v.problem}
            sys.stdout.write(json.dumps(line) + "\n")
            sys.stdout.flush()
        os._exit(0)  # nothing of rclpy's teardown can crash a run whose verdicts are all out


@dataclass
class ChildRun:
    verdicts: dict[int, Verdict] = field(default_factory=dict)
    crashes: list[str] = field(default_factory=list)  # "sequence N: signal S"


def run_sequences_in_children(
    count: int, length: int, *, max_crashes: int = 3, env: dict[str, str] | None = None
) -> ChildRun:
    """Run ``count`` sequences in child processes, surviving up to ``max_crashes`` crashes."""
    import json
    import signal
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    run = ChildRun()
    nxt = 0
    while nxt < count:
        code = f"from tests.conformance import ros_oracle as ro; ro.main_sequences({nxt}, {count}, {length})"
        proc = subprocess.run(
            [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=600,
            env={**os.environ, **(env or {})},
        )
        for line in proc.stdout.splitlines():
            d = json.loads(line)
            run.verdicts[d["i"]] = Verdict(ops=d["ops"], differences=d["differences"], problem=d["problem"])
        done = max(run.verdicts, default=-1) + 1
        if proc.returncode == 0 and done == count:
            break
        if proc.returncode >= 0 or len(run.crashes) >= max_crashes:
            raise RuntimeError(
                f"the oracle's child stopped at sequence {done} with exit {proc.returncode} "
                f"(crashes before: {run.crashes}):\n{proc.stderr[-3000:]}"
            )
        run.crashes.append(f"sequence {done}: {signal.Signals(-proc.returncode).name}")
        nxt = done
    return run
