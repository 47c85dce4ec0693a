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

from cyclonedds.domain import DomainParticipant

from ..core.names import canonical_node_id
from ..core.request import ParamsArg, to_parameters
from .qos import QosProfiles
from .transport import Writers, transport_of
from .wire import types as wire
from .wire.convert import parameter_to_wire


class Assigner:
    def __init__(self, participant: DomainParticipant, qos: QosProfiles | None = None) -> None:
        self._qos = (qos or QosProfiles.load()).assignment_writer()
        # plain: the one writer, made now; secure: a writer per node, in its partition, made on use
        self._writers = Writers(transport_of(participant))
        self._writers.early("SetParametersRequest", self._qos)
        self.client_id = secrets.randbits(64) or 1
        self._ids = itertools.count(1)

    def assign(self, node: str, params: ParamsArg) -> None:
        """Retain ``params`` for ``node`` (replacing what this assigner held for it)."""
        node = canonical_node_id(node)
        writer = self._writers.get("SetParametersRequest", node, self._qos)
        writer.write(
            wire.SetParametersRequest(
                node_id=node,
                client_id=self.client_id,
                request_id=next(self._ids),
                retained=True,
                parameters=[parameter_to_wire(p) for p in to_parameters(params)],
            )
        )
