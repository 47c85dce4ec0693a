"""A live node's parameters with their descriptors, read as ``dump`` and ``schema NODE`` read them."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..core.descriptors import ParameterDescriptor
    from ..core.results import GetResult
    from ..core.values import ParameterValue
    from ..dds.client import ParameterClient

Snapshot = list[tuple[str, "ParameterValue", "ParameterDescriptor"]]


def node_snapshot(args: argparse.Namespace, node: str) -> tuple[Snapshot, list[GetResult]]:
    """Every parameter of ``node`` (list, then one get with descriptors): (name, value,
    descriptor) for each one that has a value, and the results of the names that vanished
    between the two calls."""
    from ..session import Session

    with Session(args) as session:
        return snapshot_of(session.client(), node)


def snapshot_of(client: ParameterClient, node: str) -> tuple[Snapshot, list[GetResult]]:
    """:func:`node_snapshot` with a client the caller holds (several nodes, one session)."""
    from ..core.descriptors import ParameterDescriptor

    names = client.list(node).names
    reply = client.get(node, list(names), with_descriptors=True)
    snapshot = [
        (r.name, r.value, r.descriptor or ParameterDescriptor(r.name, r.value.type))
        for r in reply.results
        if r.value is not None
    ]
    return snapshot, reply.missing()
