"""Two sets of parameter values compared: what only one side has, and what differs.

Pure: values in, differences out (``paramdds diff`` renders them). Values are compared
exactly (:meth:`~.values.ParameterValue.same_as`: NaN equals NaN, ``-0.0`` is not
``0.0``, ``2`` is not ``2.0``: the caller reads a file's values as the node holds them first).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum

from .jsonform import json_value
from .values import ParameterValue

__all__ = ["DiffKind", "Difference", "compare", "difference_json"]


class DiffKind(str, Enum):
    ONLY_A = "only_a"  # the parameter is on side A alone
    ONLY_B = "only_b"
    CHANGED = "changed"  # on both sides, with different values


@dataclass(frozen=True, slots=True)
class Difference:
    """One parameter that differs: ``a`` None when only B has it, ``b`` None when only A does."""

    name: str
    a: ParameterValue | None
    b: ParameterValue | None

    @property
    def kind(self) -> DiffKind:
        if self.b is None:
            return DiffKind.ONLY_A
        if self.a is None:
            return DiffKind.ONLY_B
        return DiffKind.CHANGED


def compare(a: Mapping[str, ParameterValue], b: Mapping[str, ParameterValue]) -> list[Difference]:
    """Every parameter that differs between ``a`` and ``b``, by name."""
    out: list[Difference] = []
    for name in sorted(a.keys() | b.keys()):
        va, vb = a.get(name), b.get(name)
        if va is not None and vb is not None and va.same_as(vb):
            continue
        out.append(Difference(name, va, vb))
    return out


def difference_json(d: Difference) -> dict[str, object]:
    """One difference as ``diff -o json`` prints it: ``name``, ``kind``, and ``a``/``b``
    (the value's JSON form; absent on the side that lacks the parameter)."""
    out: dict[str, object] = {"name": d.name, "kind": d.kind.value}
    if d.a is not None:
        out["a"] = json_value(d.a)
    if d.b is not None:
        out["b"] = json_value(d.b)
    return out
