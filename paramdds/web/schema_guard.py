"""``paramdds web --schema NODE=FILE``: the console checks a write against the node's JSON
Schema before sending it, with the node's own rule and reason (the node still checks).

The check is :meth:`paramdds.formats.schema.NodeSchema.node_validator`, the one a node
declared by ``paramdds server --schema FILE`` runs, on the console's view of the node's
values: a plain set checks each parameter on the state the ones before it leave (only
those that pass are sent), an atomic set checks them together (nothing is sent when it
fails). A refusal is a result row like the node's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..core.values import NOT_SET, Parameter, ParameterType, ParameterValue
from ..errors import ErrorCode
from .model import Row

__all__ = ["precheck"]


def _apply(state: dict[str, ParameterValue], p: Parameter) -> dict[str, ParameterValue]:
    after = dict(state)
    value = p.value if isinstance(p.value, ParameterValue) else NOT_SET
    if value.type is ParameterType.NOT_SET:
        after.pop(p.name, None)
    else:
        after[p.name] = value
    return after


def _row(name: str, reason: str) -> Row:
    return {"name": name, "successful": False, "reason": reason, "code": ErrorCode.INVALID_VALUE.value}


def precheck(
    schema: Any, current: Mapping[str, tuple[ParameterValue, Any]], params: Sequence[Parameter], atomic: bool
) -> tuple[list[Parameter], list[Row]]:
    """(the parameters to send, the rows of those the schema refuses)."""
    check = schema.node_validator()
    state = {n: v for n, (v, _) in current.items() if v.type is not ParameterType.NOT_SET}
    if atomic:
        after = state
        for p in params:
            after = _apply(after, p)
        refusal = check(after, {p.name: state.get(p.name) for p in params})
        if refusal is None:
            return list(params), []
        blamed, reason = refusal
        other = f"not applied: the atomic set failed on {blamed!r}"
        return [], [_row(p.name, reason if not blamed or p.name == blamed else other) for p in params]
    send: list[Parameter] = []
    refused: list[Row] = []
    for p in params:
        after = _apply(state, p)
        refusal = check(after, {p.name: state.get(p.name)})
        if refusal is None:
            send.append(p)
            state = after
        else:
            refused.append(_row(p.name, refusal[1]))
    return send, refused
