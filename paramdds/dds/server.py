"""The parameter server: hosts one or many node ids behind seven global topics.

How it works:

* Each request topic is read by one content-filtered reader (:mod:`.filters`): a
  native C filter on the node ids hosted here, updated by ``add_node`` and
  ``remove_node``, so Cyclone drops other nodes' requests before Python sees
  them. (A *Python* filter would deadlock: it runs on Cyclone's receive thread
  under the reader's lock and waits for the GIL, which ``take`` holds while it
  waits for that lock.) The handlers still ignore requests for node ids not
  hosted here: that is the whole filter where the extension is not built.
* One dispatch thread wakes on a WaitSet, applies each request atomically through
  the node's :class:`~paramdds.core.table.ParameterTable`, and answers with the
  requester's ``client_id`` and ``request_id``.
* Parameter state goes to ``ParameterEvents`` keyed by (node_id, name): declare and
  change write, delete disposes, a graceful stop unregisters (the State profile
  turns autodispose off, so readers see "no writers", not "deleted"). Each node
  also keeps a presence instance (name ``""``) with host, pid, revision and count.
* A set's reply is written before its state samples, so publishing state does not
  add to the round trip. With ``before_reply`` hooks (persistence) a change is on
  disk before it is acknowledged.
* Retained assignments arrive on ``SetParametersRequest`` with ``retained=True``
  from a TRANSIENT_LOCAL writer; a second, TRANSIENT_LOCAL reader takes them. The
  interactive (VOLATILE) reader ignores them and the assignment reader never sees
  interactive requests (a VOLATILE writer does not match a TRANSIENT_LOCAL reader).
* Retried requests (same client_id, request_id and content) get the cached reply
  again and are never applied twice. The same ids with other content are a new
  request: a client restarted with a fixed client_id counts from 1 again and must
  not be answered with the previous run's replies.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import Any

from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from ..core.limits import MAX_PARAMETERS_PER_REQUEST
from ..core.names import canonical_node_id
from ..core.results import ChangeKind, ChangeSet, SetResult
from ..core.table import ParameterTable
from ..core.values import Parameter
from ..errors import ErrorCode, NotPersistedError, ParamddsError
from . import types as wire
from ._binding import write_serialized
from .convert import descriptor_to_wire, parameter_from_wire, state_descriptor_to_wire, value_to_wire
from .dispatch import Dispatcher
from .filters import NativeFilter, filtered_topic
from .qos import QosProfiles
from .state import encode_state

log = logging.getLogger(__name__)

DEDUP_WINDOW = 4096  # replies kept for retried requests, per server
BeforeReply = Callable[[str, ParameterTable, ChangeSet], None]


def now_stamp() -> wire.Time:
    ns = time.time_ns()
    return wire.Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class ParameterServer:
    """Serves the tables it hosts. ``start()`` begins serving, ``close()`` stops gracefully."""

    def __init__(self, participant: Any, qos: QosProfiles | None = None) -> None:
        self._dp = participant
        self._qos = qos or QosProfiles.load()
        self._tables: dict[str, ParameterTable] = {}
        self._listener_handles: dict[str, object] = {}
        self._host = socket.gethostname()
        self._pid = os.getpid()
        self._lock = threading.Lock()
        self._deferred: list[ChangeSet] | None = None
        # (node, client_id, request_id) -> (request content, reply), for retried requests
        self._replies: OrderedDict[tuple[str, int, int], tuple[Any, Any]] = OrderedDict()
        self._logged_bad: set[str] = set()
        self.before_reply: list[BeforeReply] = []
        self._closed = False
        self._filter = NativeFilter("nodes")  # the request readers' filter: the nodes hosted here
        self.foreign_requests = 0  # requests that reached a handler for a node not hosted here

        self._state_writer = DataWriter(
            participant,
            Topic(participant, "ParameterEvents", wire.ParameterEvent),
            self._qos.writer("ParameterEvents"),
        )
        self._reply_writers = {
            name: DataWriter(participant, Topic(participant, name, wire.TOPICS[name]), self._qos.writer(name))
            for name in ("SetParametersResponse", "GetParametersResponse", "ListParametersResponse")
        }
        self._dispatcher = Dispatcher(participant, "paramdds-server")
        handlers = {
            "SetParametersRequest": self._on_set,
            "GetParametersRequest": self._on_get,
            "ListParametersRequest": self._on_list,
        }
        for name, handler in handlers.items():
            reader = DataReader(participant, self._request_topic(name), self._qos.reader(name))
            self._dispatcher.add(reader, handler)

    def _request_topic(self, name: str) -> Any:
        return filtered_topic(self._dp, name, wire.TOPICS[name], self._filter)

    @property
    def filter(self) -> NativeFilter:
        """The request readers' filter (``filter.native`` is False where the extension is missing)."""
        return self._filter

    # -- hosting -----------------------------------------------------------------

    def add_node(self, table: ParameterTable) -> None:
        """Host ``table``: publish its state and presence and serve its requests."""
        node_id = table.node_id
        if node_id in self._tables:
            raise ParamddsError(f"node {node_id!r} is already hosted by this server")
        self._tables[node_id] = table
        self._filter.set_nodes(self._tables)
        self._listener_handles[node_id] = table.add_change_listener(self._on_change)
        for name, value, descriptor in table.snapshot():
            self._write_state(table, name, value, descriptor, table.revision)
        self._write_presence(table)

    def remove_node(self, node_id: str) -> None:
        """Stop hosting ``node_id`` gracefully: its instances become "no writers", not deleted."""
        table = self._tables.pop(node_id)
        self._filter.set_nodes(self._tables)
        table.remove_change_listener(self._listener_handles.pop(node_id))
        for name in [*table.names(), ""]:
            self._state_writer.unregister_instance(wire.ParameterEvent(node_id=node_id, name=name))

    @property
    def nodes(self) -> dict[str, ParameterTable]:
        return dict(self._tables)

    def start(self) -> ParameterServer:
        """Serve. Retained assignments for the nodes hosted now are applied from here on.

        The assignment reader is created here, after the nodes are added, because it
        takes the retained samples once, when they are delivered, and ignores those
        of nodes not hosted then.
        """
        reader = DataReader(
            self._dp, self._request_topic("SetParametersRequest"), self._qos.assignment_reader()
        )
        self._dispatcher.add(reader, self._on_assignment)
        self._dispatcher.start()
        return self

    def close(self) -> None:
        """Graceful stop: unregister every instance (readers see the nodes offline)."""
        if self._closed:
            return
        self._closed = True
        self._dispatcher.close()
        for node_id in list(self._tables):
            self.remove_node(node_id)

    def __enter__(self) -> ParameterServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- state publication ---------------------------------------------------------

    def _write_state(
        self, table: ParameterTable, name: str, value: Any, descriptor: Any, revision: int
    ) -> None:
        """Publish one parameter's state; the common shape is encoded without a wire object."""
        sec, nanosec = divmod(time.time_ns(), 1_000_000_000)
        data = encode_state(table.node_id, name, revision, sec, nanosec, value, descriptor)
        if data is not None:
            write_serialized(self._state_writer, data)
            return
        self._state_writer.write(
            wire.ParameterEvent(
                node_id=table.node_id,
                name=name,
                kind=wire.EVENT_PARAMETER,
                revision=revision,
                stamp=wire.Time(sec, nanosec),
                value=value_to_wire(value),
                descriptor=state_descriptor_to_wire(descriptor, value),
            )
        )

    def _write_presence(self, table: ParameterTable) -> None:
        self._state_writer.write(
            wire.ParameterEvent(
                node_id=table.node_id,
                name="",
                kind=wire.EVENT_PRESENCE,
                revision=table.revision,
                stamp=now_stamp(),
                host=self._host,
                pid=self._pid,
                parameter_count=len(table),
            )
        )

    def _on_change(self, change: ChangeSet) -> None:
        if self._deferred is not None and threading.get_ident() == self._dispatcher.thread_ident:
            self._deferred.append(change)
        else:
            self._publish(change)

    def _publish(self, change: ChangeSet) -> None:
        table = self._tables.get(change.node_id)
        if table is None:
            return
        for item in change.changes:
            if item.kind is ChangeKind.DELETED:
                self._state_writer.dispose(wire.ParameterEvent(node_id=change.node_id, name=item.name))
            else:
                self._write_state(table, item.name, item.value, item.descriptor, change.revision)
        self._write_presence(table)

    def _flush_deferred(self) -> None:
        deferred, self._deferred = self._deferred or [], None
        for change in deferred:
            self._publish(change)

    # -- requests -------------------------------------------------------------------

    def _table_for(self, node_id: str) -> ParameterTable | None:
        table = self._tables.get(node_id)
        if table is None:
            try:
                table = self._tables.get(canonical_node_id(node_id))
            except ParamddsError:
                table = None
        if table is None:
            self.foreign_requests += 1
        return table

    def _on_set(self, samples: Sequence[Any]) -> None:
        for request in samples:
            # assignments (retained) are taken by the assignment reader
            if request.sample_info.valid_data and not request.retained:
                self._handle_set(request, reply=True)

    def _on_assignment(self, samples: Sequence[Any]) -> None:
        for request in samples:
            if request.sample_info.valid_data and request.retained:
                self._handle_set(request, reply=False)

    def _handle_set(self, request: Any, *, reply: bool) -> None:
        table = self._table_for(request.node_id)
        if table is None:
            return
        key = (table.node_id, request.client_id, request.request_id)
        content = (request.atomic, request.expected_revision, request.parameters)
        if reply:
            seen = self._replies.get(key)
            # a retry carries the same content; the same ids with other content are a new
            # request (a client restarted with a fixed client_id counts from 1 again)
            if seen is not None and seen[0] == content:
                self._send_reply("SetParametersResponse", seen[1])
                return
        response = wire.SetParametersResponse(
            node_id=table.node_id, client_id=request.client_id, request_id=request.request_id
        )
        self._deferred = []
        try:
            response.results, response.revision = self._apply_set(table, request)
        except ParamddsError as exc:
            response.code, response.reason, response.revision = exc.code.value, exc.message, table.revision
        except Exception as exc:  # never let a bad request take the server down
            log.exception("set request on %s failed", table.node_id)
            response.code, response.reason = ErrorCode.INVALID_VALUE.value, f"internal error: {exc}"
            response.revision = table.revision
        try:
            if reply:
                self._remember(key, content, response)
                self._send_reply("SetParametersResponse", response)
            elif not all(r.successful for r in response.results) or response.code:
                log.warning("assignment for %s partly refused: %s", table.node_id, _summary(response))
        finally:
            self._flush_deferred()

    def _apply_set(self, table: ParameterTable, request: Any) -> tuple[list[Any], int]:
        count = len(request.parameters)
        if count > MAX_PARAMETERS_PER_REQUEST:
            raise ParamddsError(
                f"a set of {count} parameters exceeds the limit of {MAX_PARAMETERS_PER_REQUEST}",
                code=ErrorCode.TOO_LARGE,
            )
        params: list[Parameter | None] = []
        bad: dict[int, SetResult] = {}
        for i, p in enumerate(request.parameters):
            try:
                params.append(parameter_from_wire(p))
            except ParamddsError as exc:
                params.append(None)
                bad[i] = SetResult(p.name, False, exc.message, exc.code)
                who = request.client_id
                self._log_once("malformed-value", "bad value for %r from client %x: %s", p.name, who, exc)
        expected = None if request.expected_revision < 0 else int(request.expected_revision)
        good = [p for p in params if p is not None]
        if bad and request.atomic:
            first = next(iter(bad.values())).name
            refused = [
                bad.get(i)
                or SetResult(
                    p.name, False, f"not applied: the atomic set failed on {first!r}", ErrorCode.INVALID_VALUE
                )
                for i, p in enumerate(request.parameters)
            ]
            return [_result_to_wire(r) for r in refused], table.revision
        outcome = (table.set_atomically if request.atomic else table.set)(good, expected_revision=expected)
        if outcome.change is not None:
            self._run_hooks(table, outcome.change)
        merged = iter(outcome.results)
        results = [bad[i] if i in bad else next(merged) for i in range(len(params))]
        return [_result_to_wire(r) for r in results], outcome.revision

    def _run_hooks(self, table: ParameterTable, change: ChangeSet) -> None:
        """Run the ``before_reply`` hooks; a failure is NOT_PERSISTED (the change stays applied)."""
        for hook in self.before_reply:
            try:
                hook(table.node_id, table, change)
            except Exception as exc:
                log.exception("persisting %s at revision %d failed", table.node_id, change.revision)
                raise NotPersistedError(
                    f"applied at revision {change.revision}, but not persisted: {exc}; "
                    "the value holds until the server restarts"
                ) from exc

    def _send_reply(self, topic: str, response: Any) -> None:
        """Write a reply; a failed write is logged and never loses the rest of the batch."""
        try:
            self._reply_writers[topic].write(response)
        except Exception as exc:
            who = response.client_id
            self._log_once(f"write:{topic}", "could not send a %s to client %x: %s", topic, who, exc)

    def _log_once(self, kind: str, message: str, *args: object) -> None:
        """Log a problem caused by peers once per kind, so a faulty peer cannot flood the log."""
        if kind not in self._logged_bad:
            self._logged_bad.add(kind)
            log.warning(message + " (further ones are not logged)", *args)

    def _remember(self, key: tuple[str, int, int], content: tuple[Any, ...], response: Any) -> None:
        self._replies.pop(key, None)  # re-inserted at the end: the window keeps the newest
        self._replies[key] = (content, response)
        while len(self._replies) > DEDUP_WINDOW:
            self._replies.popitem(last=False)

    def _on_get(self, samples: Sequence[Any]) -> None:
        self._answer(samples, "GetParametersResponse", _fill_get)

    def _on_list(self, samples: Sequence[Any]) -> None:
        self._answer(samples, "ListParametersResponse", _fill_list)

    def _answer(self, samples: Sequence[Any], reply_topic: str, fill: Fill) -> None:
        """Answer read-only requests: ``fill(table, request, response)`` does the work.

        Requests for nodes not hosted here are ignored; a refusal becomes the reply's
        code and reason, and no exception escapes to take the server down.
        """
        reply_type: Any = wire.TOPICS[reply_topic]
        for request in samples:
            if not request.sample_info.valid_data:
                continue
            table = self._table_for(request.node_id)
            if table is None:
                continue
            response = reply_type(
                node_id=table.node_id, client_id=request.client_id, request_id=request.request_id
            )
            try:
                fill(table, request, response)
                response.revision = table.revision
            except ParamddsError as exc:
                response.code, response.reason = exc.code.value, exc.message
            except Exception as exc:
                log.exception("%s on %s failed", type(request).__name__, table.node_id)
                response.code, response.reason = ErrorCode.INVALID_VALUE.value, f"internal error: {exc}"
            self._send_reply(reply_topic, response)


Fill = Callable[[ParameterTable, Any, Any], None]


def _fill_get(table: ParameterTable, request: Any, response: Any) -> None:
    if len(request.names) > MAX_PARAMETERS_PER_REQUEST:
        raise ParamddsError(
            f"a get of {len(request.names)} names exceeds the limit of {MAX_PARAMETERS_PER_REQUEST}",
            code=ErrorCode.TOO_LARGE,
        )
    results = table.get_many(list(request.names), with_descriptors=request.with_descriptors)
    response.results = [
        wire.GetParameterResult(
            name=r.name,
            code=r.code.value if r.code else "",
            reason=r.reason,
            value=value_to_wire(r.value) if r.value is not None else wire.ParameterValue(),
            descriptor=[descriptor_to_wire(r.descriptor)] if r.descriptor is not None else [],
        )
        for r in results
    ]


def _fill_list(table: ParameterTable, request: Any, response: Any) -> None:
    result = table.list(list(request.prefixes), int(request.depth))
    response.names, response.prefixes = list(result.names), list(result.prefixes)


def _result_to_wire(r: SetResult) -> Any:
    return wire.SetParameterResult(
        name=r.name, successful=r.successful, reason=r.reason, code=r.code.value if r.code else ""
    )


def _summary(response: Any) -> str:
    if response.code:
        return f"{response.code}: {response.reason}"
    return "; ".join(f"{r.name}: {r.reason}" for r in response.results if not r.successful)
