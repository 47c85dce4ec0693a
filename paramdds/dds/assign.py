"""Retained assignments: desired values that reach a node whenever it starts.

An :class:`Assigner` writes one ``SetParametersRequest`` per node with
``retained=True`` through a TRANSIENT_LOCAL writer (the Assignment profile,
KEEP_LAST 1 per node). A server applies it through the same validation as any
set, when it starts or when the assignment changes. It never rides the
interactive path: interactive readers are VOLATILE and skip retained samples, and
a VOLATILE request writer does not match the TRANSIENT_LOCAL assignment reader.
TRANSIENT_LOCAL data lives as long as its writer, so the assigner stays up.
"""

from __future__ import annotations

import itertools
import secrets
from typing import Any

from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic

from ..core.names import canonical_node_id
from ..secure.scope import scope_of
from .client import ParamsArg, _to_parameters
from .qos import QosProfiles
from .wire import types as wire
from .wire.convert import parameter_to_wire


class Assigner:
    def __init__(self, participant: Any, qos: QosProfiles | None = None) -> None:
        qos = qos or QosProfiles.load()
        topic = Topic(participant, "SetParametersRequest", wire.SetParametersRequest)
        # secure mode: a writer per node, in its partition (paramdds.secure.scope), made on use
        self._scope = scope_of(participant)
        self._topic, self._qos = topic, qos.assignment_writer()
        if self._scope is None:
            self._writer = DataWriter(participant, topic, self._qos)
        self.client_id = secrets.randbits(64) or 1
        self._ids = itertools.count(1)

    def assign(self, node: str, params: ParamsArg) -> None:
        """Retain ``params`` for ``node`` (replacing what this assigner held for it)."""
        node = canonical_node_id(node)
        scope = self._scope
        writer = self._writer if scope is None else scope.writer("SetParametersRequest", node, self._qos)
        writer.write(
            wire.SetParametersRequest(
                node_id=node,
                client_id=self.client_id,
                request_id=next(self._ids),
                retained=True,
                parameters=[parameter_to_wire(p) for p in _to_parameters(params)],
            )
        )
