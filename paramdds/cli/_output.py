"""What the CLI prints: the JSON shapes (:mod:`paramdds.core.jsonform`) rendered as
tables, YAML or JSON, and one line on stderr per problem.

Pure functions; no DDS here.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..core.values import ParameterType, ParameterValue
from ..exits import one_line

if TYPE_CHECKING:
    from ..dds.client import SetReply



def dumps_json(obj: object, *, pretty: bool = True) -> str:
    """JSON text; refuses NaN (values must go through :func:`paramdds.core.jsonform.json_value` first)."""
    return json.dumps(obj, indent=2 if pretty else None, ensure_ascii=False, allow_nan=False)

def dumps_yaml(obj: object) -> str:
    import yaml

    return str(yaml.safe_dump(obj, sort_keys=False, allow_unicode=True, default_flow_style=None))


def typed(value: ParameterValue | None) -> str:
    """``double 1.5`` — a value with its type, as the demo and table outputs print it."""
    if value is None or value.type is ParameterType.NOT_SET:
        return "not_set"
    return f"{value.type.label} {value.show()}"


def emit(output: str, data: object, table: str | None = None) -> None:
    """Print ``data`` as JSON or YAML, or ``table`` (pre-rendered text) for the table format."""
    if output == "json":
        text = dumps_json(data)
    elif output == "yaml":
        text = dumps_yaml(data).rstrip("\n")
    else:
        text = table if table is not None else dumps_yaml(data).rstrip("\n")
    if text:
        sys.stdout.write(text + "\n")
    sys.stdout.flush()


def describe_table(descriptors: Mapping[str, Mapping[str, Any]]) -> str:
    """Descriptors as indented ``key: value`` blocks, skipping empty fields; a range as
    :func:`range_text` reads it (a range that bounds nothing is an empty field); the last
    change (``last_change``, a :meth:`~paramdds.core.results.LastChange.to_json`) as
    :func:`last_change_text` reads it, nothing when it is unknown."""
    lines: list[str] = []
    for name, d in descriptors.items():
        lines.append(f"{name}:")
        for key, value in d.items():
            if key == "last_change":
                if isinstance(value, Mapping):
                    lines.append(f"  last change: {last_change_text(value)}")
                continue
            if key in _RANGES and isinstance(value, Mapping):
                value = range_text(value, floating=key == "floating_point_range")
            if value in (None, "", [], False) and key not in ("type", "read_only"):
                continue
            lines.append(f"  {key}: {value if key in _RANGES else dumps_json(value, pretty=False)}")
    return "\n".join(lines)


_RANGES = ("integer_range", "floating_point_range")


def last_change_text(lc: Mapping[str, Any]) -> str:
    """A last change (its JSON shape) as a person reads it: ``alice@robot-host (claimed) via
    cli at 2026-11-29T01:02:03.456789Z, revision 7``; an identity the node did not verify is
    marked "claimed", and an unknown author is "unknown"."""
    who = str(lc.get("who") or "unknown")
    claimed = "" if lc.get("verified") else " (claimed)"
    via = f" via {lc['via']}" if lc.get("via") else ""
    return f"{who}{claimed}{via} at {lc.get('time')}, revision {lc.get('revision')}"


_INT64 = (-(2**63), 2**63 - 1)


def range_text(r: Mapping[str, Any], *, floating: bool) -> str:
    """A range (its JSON shape) as a person reads it: ``[0.0, 5.0]``, ``[0, 10] step 2``, or
    ``≥ 1.0`` / ``≤ 1.0`` when one end is the type's limit (±1.7976931348623157e+308 or an
    infinity for a double, int64's for an integer), which bounds nothing; ``""`` when both are."""
    lo, hi, step = r["from_value"], r["to_value"], r.get("step") or 0
    lo_open, hi_open = _open_end(lo, floating, low=True), _open_end(hi, floating, low=False)
    grid = f" step {dumps_json(step)}" if step else ""
    if lo_open and hi_open:
        return grid.strip()
    if hi_open:
        return f"≥ {dumps_json(lo)}{grid}"
    if lo_open:
        return f"≤ {dumps_json(hi)}{grid}"
    return f"[{dumps_json(lo)}, {dumps_json(hi)}]{grid}"


def _open_end(x: object, floating: bool, *, low: bool) -> bool:
    """True when the end ``x`` of a range bounds nothing (see :func:`range_text`)."""
    if isinstance(x, str):  # "inf", "-inf": JSON has no infinities
        return x == ("-inf" if low else "inf")
    if not isinstance(x, (int, float)):
        return False
    limit = (-sys.float_info.max, sys.float_info.max) if floating else _INT64
    return x <= limit[0] if low else x >= limit[1]


def results_table(results: Mapping[str, Mapping[str, object]], revision: int) -> str:
    """Set/delete results: ``name: ok`` or ``name: FAILED: reason``, then the revision."""
    lines = []
    for name, r in results.items():
        reason = str(r["reason"])
        if r["successful"] and reason == "unchanged":
            lines.append(f"{name}: unchanged")
        elif r["successful"]:
            lines.append(f"{name}: ok" + (f" ({reason})" if reason else ""))
        else:
            lines.append(f"{name}: FAILED: {reason}")
    lines.append(f"revision: {revision}")
    return "\n".join(lines)


def problem(message: str) -> None:
    """One line on stderr about one thing that failed."""
    sys.stderr.write(f"paramdds: error: {one_line(message)}\n")


def report_missing(node: str, missing: Sequence[object]) -> int:
    """One line on stderr per name the node lacks; the exit code (1 if any)."""
    from ..exits import Exit

    for r in missing:
        problem(getattr(r, "reason", "") or f"{getattr(r, 'name', '?')}: not found on {node!r}")
    return Exit.REFUSED if missing else Exit.OK


def report_set(output: str, node: str, reply: SetReply) -> int:
    """Print a set/delete/load reply; exit 1 when any parameter failed."""
    from ..exits import Exit

    results: dict[str, dict[str, object]] = {
        r.name: {"successful": r.successful, "reason": r.reason} for r in reply.results
    }
    data: dict[str, object] = {**results, "revision": reply.revision}
    emit(output, data, results_table(results, reply.revision))
    failed = [r for r in reply.results if not r.successful]
    if failed:
        problem(
            f"{len(failed)} of {len(reply.results)} parameters refused by node {node!r}: "
            + "; ".join(f"{r.name}: {r.reason}" for r in failed)
        )
        return Exit.REFUSED
    return Exit.OK
