"""Loading a parameter file onto a node: only what it changes is sent.

A dump loads back as a no-op: every value the node already holds (read-only ones
included) is skipped and reported ``unchanged``; a load that changes nothing sends no
request, so it raises no revision and emits no event (``--atomic`` the same: only the
values that differ are applied, all or nothing). Values are compared as the node would
hold them: a file's ``2`` for a double parameter of a fixed type is ``2.0``
(:func:`paramdds.core.fit.fit_value`), NaN equals NaN, ``-0.0`` is not ``0.0``
(:meth:`~paramdds.core.values.ParameterValue.same_as`). A name the node does not
declare is sent: the node decides (refused, or declared with ``--allow-undeclared``).
The file's descriptors (a dump's ``paramdds__descriptors``) are not loaded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .core.results import SetResult

if TYPE_CHECKING:
    from .core.descriptors import ParameterDescriptor
    from .core.results import GetResult
    from .core.values import Parameter, ParameterValue
    from .dds.client import ParameterClient, SetReply

UNCHANGED = "unchanged"


@dataclass(frozen=True)
class LoadPlan:
    """What a load sends (``changed``) and what it skips (``unchanged``), in file order."""

    order: tuple[str, ...]
    changed: tuple[Parameter, ...]
    unchanged: tuple[str, ...]


def unchanged(
    name: str, value: ParameterValue, held: ParameterValue, descriptor: ParameterDescriptor | None
) -> bool:
    """Whether setting ``value`` on a parameter that holds ``held`` changes nothing (the
    one rule of ``load`` in the CLI, the web console and the demo client)."""
    from .core.fit import fit_value
    from .errors import ParamddsError

    try:
        fitted = fit_value(name, value, descriptor)
    except ParamddsError:  # not a value of this parameter: a change the node will refuse
        return False
    return fitted.same_as(held)


def plan_load(params: Sequence[Parameter], current: Sequence[GetResult]) -> LoadPlan:
    """Split ``params`` into the values that change the node and those it already holds.

    ``current`` is the node's answer to a get (with descriptors) of the same names.
    """
    held = {r.name: r for r in current if r.value is not None}
    changed: list[Parameter] = []
    skipped: list[str] = []
    for p in params:
        r = held.get(p.name)
        if r is not None and r.value is not None and unchanged(p.name, p.value, r.value, r.descriptor):
            skipped.append(p.name)
        else:
            changed.append(p)
    return LoadPlan(tuple(p.name for p in params), tuple(changed), tuple(skipped))


def load(
    client: ParameterClient, node: str, params: Sequence[Parameter], *, atomic: bool = False
) -> SetReply:
    """Set on ``node`` the values of ``params`` that differ from what it holds.

    The reply lists every parameter in file order; the skipped ones are successful with
    reason ``"unchanged"``. When nothing differs no set is sent and the revision is the
    one the get read.
    """
    from .dds.client import SetReply

    current = client.get(node, [p.name for p in params], with_descriptors=True)
    plan = plan_load(params, current.results)
    results: dict[str, SetResult] = {n: SetResult(n, True, UNCHANGED) for n in plan.unchanged}
    if not plan.changed:
        return SetReply(
            current.node, current.revision, tuple(results[n] for n in plan.order), current.incarnation
        )
    reply = client.set(node, list(plan.changed), atomic=atomic)
    results.update((r.name, r) for r in reply.results)
    ordered = [results[n] for n in plan.order if n in results]
    ordered += [r for r in reply.results if r.name not in plan.order]
    return SetReply(reply.node, reply.revision, tuple(ordered), reply.incarnation)
