"""Retained assignments: desired values that reach a node whenever it starts.

An :class:`Assigner` writes one ``SetParametersRequest`` per node with
``retained=True`` through a TRANSIENT_LOCAL writer (the Assignment profile,
KEEP_LAST 1 per node). A server applies it through the same validation as any
set, when it starts or when the assignment changes. It never rides the
interactive path: interactive readers are VOLATILE and skip retained samples, and
a VOLATILE request writer does not match the TRANSIENT_LOCAL assignment reader.
TRANSIENT_LOCAL data lives as long as its writer, so the assigner stays up.

A server answers each assignment it applies (when it starts, or when the assignment
changes) with a ``SetParametersResponse`` to the assigner's client id: an assigner made
with ``on_reply`` hears every outcome as it happens, each refusal with the node's reason.
The answers go through a TRANSIENT_LOCAL writer and reader of their own
(:meth:`~paramdds.dds.qos.QosProfiles.answer_writer`): a node may answer before the
assigner's reader has matched its writer, and a volatile answer would then be lost.
"""

from __future__ import annotations

import itertools
import secrets
from collections.abc import Callable, Sequence
from typing import Any

from cyclonedds.domain import DomainParticipant

from ..core.names import canonical_node_id
from ..core.origin import Via, local_identity
from ..core.request import ParamsArg, to_parameters
from ..core.results import SetResult
from ..errors import code_of
from .client import SetReply
from .dispatch import Dispatcher
from .filters import NativeFilter, filtered_topic
from .qos import QosProfiles
from .transport import Writers, transport_of
from .wire import types as wire
from .wire.convert import parameter_to_wire

ReplyCallback = Callable[[SetReply, str], None]
"""``on_reply(reply, error)``: a node's answer to an assignment; ``error`` is the reason the
whole assignment was refused ("" when each parameter has its own result in ``reply``)."""


class Assigner:
    def __init__(
        self,
        participant: DomainParticipant,
        qos: QosProfiles | None = None,
        *,
        on_reply: ReplyCallback | None = None,
        as_: str | None = None,
    ) -> None:
        profiles = qos or QosProfiles.load()
        self.who = as_ or local_identity()  # the identity its assignments claim
        self._qos = profiles.assignment_writer()
        transport = transport_of(participant)
        # plain: the one writer, made now; secure: a writer per node, in its partition, made on use
        self._writers = Writers(transport)
        self._writers.early("SetParametersRequest", self._qos)
        self.client_id = secrets.randbits(64) or 1
        self._ids = itertools.count(1)
        self._dispatcher: Dispatcher | None = None
        self._on_reply = on_reply
        if on_reply is not None:
            name = "SetParametersResponse"
            flt = NativeFilter("client")
            flt.set_client_id(self.client_id)
            replies = filtered_topic(participant, name, wire.TOPICS[name], flt)
            reader = transport.reader(replies, profiles.answer_reader())
            self._dispatcher = Dispatcher(participant, "paramdds-assign")
            self._dispatcher.add(reader, transport.guard(reader, self._on_replies))
            self._dispatcher.start()

    def close(self) -> None:
        if self._dispatcher is not None:
            self._dispatcher.close()

    def _on_replies(self, samples: Sequence[Any]) -> None:
        assert self._on_reply is not None
        for r in samples:
            if not r.sample_info.valid_data or r.client_id != self.client_id:
                continue
            results = tuple(SetResult(x.name, x.successful, x.reason, code_of(x.code)) for x in r.results)
            self._on_reply(
                SetReply(r.node_id, r.revision, results, r.incarnation), r.reason if r.code else ""
            )

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
                who=self.who,
                via=Via.ASSIGN.value,
            )
        )
