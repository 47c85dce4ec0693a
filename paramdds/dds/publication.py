"""The server's parts a node's commit path calls: persistence hooks, and state and presence.

:class:`~.node_worker.NodeWorker` (one per hosted node) talks to these through their
public methods (the :class:`~.node_worker.Persists` and :class:`~.node_worker.Publishes`
protocols), never to the server:

* :class:`Persistence` runs the ``persisters`` (``--persist``'s journal) on a node's
  changes, after the commit and before the reply; a failure is reported, not raised.
* :class:`StatePublication` owns the ``ParameterEvents`` writer of one server: each
  parameter's state keyed by (node_id, name) (a change writes, a delete disposes), each
  carrying its last change (revision, stamp, who, verified, via), each
  node's presence instance (name ``""``: host, pid, revision, count, tags), the
  incarnation drawn for each node it starts publishing, and the writer's
  MANUAL_BY_TOPIC liveliness (asserted by the server's dispatch loop); on the plain
  transport also each node's *claim*, a presence sample in the hosts partition where
  other servers look for a twin (see :class:`~.transport.Hosting`).
"""

from __future__ import annotations

import logging
import os
import secrets
import socket
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..core.hosted import HostedTable
from ..core.results import ChangeKind, ChangeSet, LastChange
from ._binding import assert_liveliness, flush_writes, unregister_serialized, write_serialized
from .filters import status_tag
from .wire import types as wire
from .wire.convert import state_descriptor_to_wire, value_to_wire
from .wire.state import encode_key, encode_state

__all__ = ["Persistence", "Persister", "StatePublication", "new_incarnation", "now_stamp"]

log = logging.getLogger(__name__)

# persist the changes of one node (called on its worker, before the reply); raising means
# the changes are applied but not persisted (NOT_PERSISTED)
Persister = Callable[[HostedTable, Sequence[ChangeSet]], None]


def new_incarnation() -> int:
    """A random non-zero 64-bit incarnation (0 means "none" on the wire)."""
    return secrets.randbits(64) or 1


def now_stamp() -> wire.Time:
    ns = time.time_ns()
    return wire.Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class Persistence:
    """The persistence hooks of one server: ``persisters``, run on every node's changes."""

    def __init__(self) -> None:
        self.persisters: list[Persister] = []

    def persist(self, table: HostedTable, changes: Sequence[ChangeSet]) -> str:
        """Run the persisters; what failed ("" when every one succeeded)."""
        for persist in self.persisters if changes else []:
            try:
                persist(table, changes)
            except Exception as exc:
                log.exception("persisting %s at revision %d failed", table.node_id, changes[-1].revision)
                return str(exc) or type(exc).__name__
        return ""


class StatePublication:
    """State and presence of the nodes one server hosts, on its ``ParameterEvents`` writer.

    ``hosted(node_id)`` says whether the server still hosts a node: changes of a node it
    stopped hosting are not published. ``tags`` is the presence value (a string array).
    ``claims``: the writer of the nodes' claims (None: presence is the claim, secure form).
    """

    def __init__(self, writer: Any, tags: Any, hosted: Callable[[str], bool], claims: Any = None) -> None:
        self.writer = writer
        self._claims = claims
        self.host = socket.gethostname()
        self.pid = os.getpid()
        self._tags = tags
        self._hosted = hosted
        self._incarnations: dict[str, int] = {}  # node -> its incarnation here
        self._logged = False

    # -- incarnations ---------------------------------------------------------------

    def begin(self, table: HostedTable, last: Mapping[str, LastChange] | None = None) -> None:
        """Start publishing ``table``'s node: a new incarnation, its state and its presence.

        Each parameter is published with its last change in ``last`` (the node's history:
        revision, time, who, verified, via); one without is published at the table's
        revision, now, with no author."""
        self._incarnations[table.node_id] = new_incarnation()
        last = last or {}
        for name, value, descriptor in table.snapshot():
            lc = last.get(name)
            if lc is None:
                self._state(table, name, value, descriptor, table.revision)
            else:
                self._state(
                    table, name, value, descriptor, lc.revision, lc.time_ns, lc.who, lc.verified, lc.via
                )
        self._presence(table)
        flush_writes(self.writer)
        if self._claims is not None:  # once the node's state is out: a twin that sees the claim reads it
            self._claims.write(
                wire.ParameterEvent(
                    node_id=table.node_id,
                    name="",
                    kind=wire.EVENT_PRESENCE,
                    stamp=now_stamp(),
                    host=self.host,
                    pid=self.pid,
                    incarnation=self.incarnation(table.node_id),
                )
            )

    def end(self, node_id: str, names: Sequence[str]) -> None:
        """Stop publishing: unregister the node's instances (readers see "no writers")."""
        for name in [*names, ""]:
            unregister_serialized(self.writer, encode_key(node_id, name))
        flush_writes(self.writer)
        if self._claims is not None:
            self._claims.unregister_instance(wire.ParameterEvent(node_id=node_id, name=""))
        self._incarnations.pop(node_id, None)

    def incarnation(self, node_id: str) -> int:
        """The incarnation of a node published here (0 for one that is not)."""
        return self._incarnations.get(node_id, 0)

    # -- samples (each public method flushes the writer's batch: one datagram a reader) --

    def _state(
        self,
        table: HostedTable,
        name: str,
        value: Any,
        descriptor: Any,
        revision: int,
        time_ns: int = 0,
        who: str = "",
        verified: bool = False,
        via: str = "",
    ) -> None:
        """Publish one parameter's state, stamped ``time_ns`` (0: now) with its change's blame;
        the common shape is encoded without a wire object."""
        sec, nanosec = divmod(time_ns or time.time_ns(), 1_000_000_000)
        incarnation = self.incarnation(table.node_id)
        data = encode_state(
            table.node_id, name, revision, sec, nanosec, value, descriptor, incarnation, who, verified, via
        )
        if data is not None:
            write_serialized(self.writer, data)
            return
        self.writer.write(
            wire.ParameterEvent(
                node_id=table.node_id,
                name=name,
                kind=wire.EVENT_PARAMETER,
                revision=revision,
                stamp=wire.Time(sec, nanosec),
                value=value_to_wire(value),
                descriptor=state_descriptor_to_wire(descriptor, value),
                incarnation=incarnation,
                who=who,
                verified=verified,
                via=via,
            )
        )

    def write_presence(self, table: HostedTable, *tags: str) -> None:
        """The node's presence sample; ``tags`` are said once, beside the server's own."""
        self._presence(table, *tags)
        flush_writes(self.writer)

    def _presence(self, table: HostedTable, *tags: str) -> None:
        status = getattr(table, "status", None)  # a table that knows its node is not all well
        if status and status_tag(status) not in tags:
            tags = (*tags, status_tag(status))
        value = self._tags
        if tags:
            value = wire.ParameterValue(
                type=value.type, string_array_value=[*value.string_array_value, *tags]
            )
        self.writer.write(
            wire.ParameterEvent(
                node_id=table.node_id,
                name="",
                kind=wire.EVENT_PRESENCE,
                revision=table.revision,
                stamp=now_stamp(),
                host=self.host,
                pid=self.pid,
                parameter_count=len(table),
                value=value,
                incarnation=self.incarnation(table.node_id),
            )
        )

    def publish(self, table: HostedTable, changes: Sequence[ChangeSet]) -> None:
        """Publish committed changes of a hosted node, then its presence (a local DDS failure is
        logged once: the table is right, the events are late)."""
        if not self._hosted(table.node_id):
            return
        try:
            for change in changes:
                origin = change.origin
                via = origin.via_text
                for item in change.changes:
                    if item.kind is ChangeKind.DELETED:
                        self._dispose(change.node_id, item.name)
                    else:
                        self._state(
                            table,
                            item.name,
                            item.value,
                            item.descriptor,
                            change.revision,
                            change.time_ns,
                            origin.who,
                            origin.verified,
                            via,
                        )
            self._presence(table)
            flush_writes(self.writer)
        except Exception as exc:
            if not self._logged:  # once: a faulty peer or a closing participant cannot flood the log
                self._logged = True
                log.warning(
                    "could not publish the state of %s: %s (further ones are not logged)", table.node_id, exc
                )

    def dispose(self, node_id: str, name: str) -> None:
        """A deleted parameter: dispose its instance."""
        self._dispose(node_id, name)
        flush_writes(self.writer)

    def _dispose(self, node_id: str, name: str) -> None:
        self.writer.dispose(wire.ParameterEvent(node_id=node_id, name=name))

    # -- liveliness -----------------------------------------------------------------

    def assert_alive(self) -> None:
        """The writer's MANUAL_BY_TOPIC liveliness: this server's loop runs."""
        assert_liveliness(self.writer)

    def offline(self, node_id: str) -> None:
        """Unregister a node's presence (its worker is stalled): monitors show it offline
        until its next presence sample."""
        self.writer.unregister_instance(wire.ParameterEvent(node_id=node_id, name=""))
        flush_writes(self.writer)
