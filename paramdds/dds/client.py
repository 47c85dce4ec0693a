"""Clients: request/reply over the six request/reply topics, and node presence.

Correlation: every request carries this client's random 64-bit ``client_id`` and
a request id counted from 1; the reply handler drops every reply whose
``client_id`` is not this client's, so two clients (in one process or two) never
take each other's replies, and replies are matched to calls by request id. (No
Cyclone topic filter: a Python filter deadlocks against ``take`` under load; see
:mod:`paramdds.dds.server`.) Many calls may be outstanding at
once (pipelining).

No call ever hangs: each has a timeout (default :data:`DEFAULT_TIMEOUT`). A node
that has no presence instance once the client has had ``presence_grace`` seconds
to discover the system is reported UNAVAILABLE at once; a node that goes offline
while a call waits fails that call with UNAVAILABLE; otherwise a missing answer is
a TIMEOUT naming the node and the time waited.
"""

from __future__ import annotations

import asyncio
import itertools
import secrets
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass
from typing import Any

from cyclonedds.core import InstanceState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from ..core.limits import MAX_PARAMETERS_PER_REQUEST, check_value
from ..core.names import canonical_node_id, validate_name
from ..core.table import GetResult, ListResult, SetResult
from ..core.values import NOT_SET, Parameter, ParameterValue
from ..errors import (
    ErrorCode,
    NotFoundError,
    ParamddsError,
    TimeoutError_,
    TooLargeError,
    UnavailableError,
    error_for,
)
from . import types as wire
from .convert import descriptor_from_wire, parameter_to_wire, value_from_wire
from .dispatch import Dispatcher
from .qos import QosProfiles

DEFAULT_TIMEOUT = 5.0
PRESENCE_GRACE = 1.0  # seconds after start-up before a node without presence counts as absent

ParamsArg = Mapping[str, object] | Iterable[Parameter]


@dataclass(frozen=True)
class NodeInfo:
    node: str
    online: bool
    host: str
    pid: int
    revision: int
    parameters: int


@dataclass(frozen=True)
class GetReply:
    node: str
    revision: int
    results: tuple[GetResult, ...]

    def values(self) -> dict[str, ParameterValue]:
        """The values found, by name (unknown names are in :meth:`missing`)."""
        return {r.name: r.value for r in self.results if r.value is not None}

    def missing(self) -> list[GetResult]:
        return [r for r in self.results if r.code is not None]


@dataclass(frozen=True)
class SetReply:
    node: str
    revision: int
    results: tuple[SetResult, ...]

    @property
    def successful(self) -> bool:
        return all(r.successful for r in self.results)


def _to_parameters(params: ParamsArg) -> list[Parameter]:
    if isinstance(params, Mapping):
        items = [Parameter(name, ParameterValue.from_python(v)) for name, v in params.items()]
    else:
        items = list(params)
    if len(items) > MAX_PARAMETERS_PER_REQUEST:
        raise TooLargeError(
            f"a set of {len(items)} parameters exceeds the limit of {MAX_PARAMETERS_PER_REQUEST}"
        )
    for p in items:
        validate_name(p.name)
        check_value(p.name, p.value)
    return items


class _Pending:
    __slots__ = ("future", "node")

    def __init__(self, node: str) -> None:
        self.node = node
        self.future: Future[Any] = Future()


class ParameterClient:
    """A synchronous client. Thread-safe; use one per process (or several: they never mix)."""

    def __init__(
        self,
        participant: Any,
        qos: QosProfiles | None = None,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        presence_grace: float = PRESENCE_GRACE,
        client_id: int | None = None,
    ) -> None:
        self._dp = participant
        self._qos = qos or QosProfiles.load()
        self.timeout = timeout
        self.client_id = client_id or secrets.randbits(64) or 1
        self._ids = itertools.count(1)
        self._ids_lock = threading.Lock()
        self._pending: dict[int, _Pending] = {}
        self._nodes: dict[str, NodeInfo] = {}
        self._nodes_changed = threading.Condition()
        self._started = time.monotonic()
        self._presence_grace = presence_grace
        self._writers = {
            name: DataWriter(participant, Topic(participant, name, wire.TOPICS[name]), self._qos.writer(name))
            for name in ("SetParametersRequest", "GetParametersRequest", "ListParametersRequest")
        }
        self._dispatcher = Dispatcher(participant, "paramdds-client")
        for name in ("SetParametersResponse", "GetParametersResponse", "ListParametersResponse"):
            reader = DataReader(participant, self._own_replies(name), self._qos.reader(name))
            self._dispatcher.add(reader, self._on_replies)
        presence = Topic(participant, "ParameterEvents", wire.ParameterEvent)
        self._dispatcher.add(
            DataReader(participant, presence, self._qos.reader("ParameterEvents")), self._on_presence
        )
        self._dispatcher.start()

    def _own_replies(self, name: str) -> Any:
        # every client's replies arrive here; _on_replies keeps only this client's
        return Topic(self._dp, name, wire.TOPICS[name])

    def close(self) -> None:
        self._dispatcher.close()
        for pending in list(self._pending.values()):
            if not pending.future.done():
                pending.future.set_exception(UnavailableError("the client was closed"))
        self._pending.clear()

    def __enter__(self) -> ParameterClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- presence -------------------------------------------------------------------

    def _on_presence(self, samples: Sequence[Any]) -> None:
        offline: list[str] = []
        with self._nodes_changed:
            for s in samples:
                info = s.sample_info
                if info.valid_data:
                    if s.kind != wire.EVENT_PRESENCE:
                        continue
                    self._nodes[s.node_id] = NodeInfo(
                        s.node_id,
                        info.instance_state == InstanceState.Alive,
                        s.host,
                        s.pid,
                        s.revision,
                        s.parameter_count,
                    )
                else:
                    old = self._nodes.get(s.key_sample.node_id)
                    if old is not None and s.key_sample.name == "":
                        self._nodes[old.node] = NodeInfo(
                            old.node, False, old.host, old.pid, old.revision, old.parameters
                        )
                        offline.append(old.node)
            self._nodes_changed.notify_all()
        for node in offline:
            for pending in list(self._pending.values()):
                if pending.node == node and not pending.future.done():
                    pending.future.set_exception(UnavailableError(f"node {node!r} went offline"))

    def nodes(self) -> list[NodeInfo]:
        """Every node whose presence this client has seen, sorted by name."""
        with self._nodes_changed:
            return sorted(self._nodes.values(), key=lambda n: n.node)

    def node_info(self, node: str) -> NodeInfo | None:
        with self._nodes_changed:
            return self._nodes.get(canonical_node_id(node))

    def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        """Block until ``node`` is online; UnavailableError after ``timeout`` seconds."""
        node = canonical_node_id(node)
        limit = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        with self._nodes_changed:
            while True:
                info = self._nodes.get(node)
                if info is not None and info.online:
                    return info
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise UnavailableError(f"node {node!r} is not present (waited {limit:g} s)")
                self._nodes_changed.wait(remaining)

    # -- the calls ------------------------------------------------------------------------

    def list(
        self, node: str, prefixes: Sequence[str] = (), depth: int = 0, *, timeout: float | None = None
    ) -> ListResult:
        return self._finish_list(self._wait(*self._send_list(node, prefixes, depth), timeout))

    def get(
        self, node: str, names: Sequence[str], *, with_descriptors: bool = False, timeout: float | None = None
    ) -> GetReply:
        """Values (and descriptors if asked) with a status per name; never an empty answer."""
        return self._finish_get(self._wait(*self._send_get(node, names, with_descriptors), timeout))

    def get_value(self, node: str, name: str, *, timeout: float | None = None) -> ParameterValue:
        (result,) = self.get(node, [name], timeout=timeout).results
        if result.value is None:
            raise NotFoundError(result.reason or f"parameter {name!r} not found on {node!r}")
        return result.value

    def set(
        self,
        node: str,
        params: ParamsArg,
        *,
        atomic: bool = False,
        if_revision: int | None = None,
        timeout: float | None = None,
    ) -> SetReply:
        """Set parameters: each on its own, or all-or-nothing with ``atomic``.

        ``if_revision`` applies the set only while the node's revision is still that
        number (compare-and-set); otherwise every result fails with CONFLICT.
        """
        return self._finish_set(self._wait(*self._send_set(node, params, atomic, if_revision), timeout))

    def delete(self, node: str, names: Sequence[str], *, timeout: float | None = None) -> SetReply:
        return self.set(node, [Parameter(n, NOT_SET) for n in names], timeout=timeout)

    # -- plumbing shared by the sync and async forms ---------------------------------------

    def _next_id(self) -> int:
        with self._ids_lock:
            return next(self._ids)

    def _send(self, topic: str, node: str, sample: Any) -> tuple[str, int, _Pending]:
        pending = _Pending(node)
        self._pending[sample.request_id] = pending
        try:
            self._writers[topic].write(sample)
        except Exception as exc:
            del self._pending[sample.request_id]
            raise ParamddsError(f"could not send the request to {node!r}: {exc}") from exc
        return node, sample.request_id, pending

    def _send_list(self, node: str, prefixes: Sequence[str], depth: int) -> tuple[str, int, _Pending]:
        node = canonical_node_id(node)
        if depth < 0:
            raise ParamddsError(f"depth must be 0 (recursive) or positive, got {depth}")
        sample = wire.ListParametersRequest(
            node_id=node,
            client_id=self.client_id,
            request_id=self._next_id(),
            depth=depth,
            prefixes=list(prefixes),
        )
        return self._send("ListParametersRequest", node, sample)

    def _send_get(self, node: str, names: Sequence[str], with_descriptors: bool) -> tuple[str, int, _Pending]:
        node = canonical_node_id(node)
        if len(names) > MAX_PARAMETERS_PER_REQUEST:
            raise TooLargeError(
                f"a get of {len(names)} names exceeds the limit of {MAX_PARAMETERS_PER_REQUEST}"
            )
        sample = wire.GetParametersRequest(
            node_id=node,
            client_id=self.client_id,
            request_id=self._next_id(),
            with_descriptors=with_descriptors,
            names=list(names),
        )
        return self._send("GetParametersRequest", node, sample)

    def _send_set(
        self, node: str, params: ParamsArg, atomic: bool, if_revision: int | None
    ) -> tuple[str, int, _Pending]:
        node = canonical_node_id(node)
        sample = wire.SetParametersRequest(
            node_id=node,
            client_id=self.client_id,
            request_id=self._next_id(),
            atomic=atomic,
            expected_revision=-1 if if_revision is None else if_revision,
            parameters=[parameter_to_wire(p) for p in _to_parameters(params)],
        )
        return self._send("SetParametersRequest", node, sample)

    def _on_replies(self, samples: Sequence[Any]) -> None:
        me = self.client_id
        for reply in samples:
            if not reply.sample_info.valid_data or reply.client_id != me:
                continue
            pending = self._pending.pop(reply.request_id, None)
            if pending is not None and not pending.future.done():
                pending.future.set_result(reply)

    def _phase(self, node: str, timeout: float | None) -> tuple[float, float]:
        """(seconds until presence must be seen, seconds until the call times out)."""
        limit = self.timeout if timeout is None else timeout
        grace = max(0.0, self._started + self._presence_grace - time.monotonic())
        return min(grace, limit), limit

    def _absent(self, node: str) -> bool:
        info = self._nodes.get(node)
        return info is None or not info.online

    def _wait(self, node: str, request_id: int, pending: _Pending, timeout: float | None) -> Any:
        first, limit = self._phase(node, timeout)
        started = time.monotonic()
        try:
            try:
                return pending.future.result(first)
            except FutureTimeout:
                pass
            if self._absent(node):
                raise UnavailableError(f"node {node!r} is not present")
            try:
                return pending.future.result(max(0.0, limit - (time.monotonic() - started)))
            except FutureTimeout:
                raise TimeoutError_(f"no answer from node {node!r} within {limit:g} s") from None
        finally:
            self._pending.pop(request_id, None)

    async def _await(self, node: str, request_id: int, pending: _Pending, timeout: float | None) -> Any:
        first, limit = self._phase(node, timeout)
        future = asyncio.wrap_future(pending.future)
        started = time.monotonic()
        try:
            done, _ = await asyncio.wait({future}, timeout=first)
            if done:
                return future.result()
            if self._absent(node):
                raise UnavailableError(f"node {node!r} is not present")
            done, _ = await asyncio.wait({future}, timeout=max(0.0, limit - (time.monotonic() - started)))
            if done:
                return future.result()
            raise TimeoutError_(f"no answer from node {node!r} within {limit:g} s")
        finally:
            self._pending.pop(request_id, None)
            if not future.done():
                future.cancel()

    @staticmethod
    def _check(reply: Any) -> None:
        if reply.code:
            raise error_for(reply.code, reply.reason or reply.code)

    def _finish_list(self, reply: Any) -> ListResult:
        self._check(reply)
        return ListResult(tuple(reply.names), tuple(reply.prefixes))

    def _finish_get(self, reply: Any) -> GetReply:
        self._check(reply)
        results = []
        for r in reply.results:
            code = ErrorCode(r.code) if r.code else None
            results.append(
                GetResult(
                    name=r.name,
                    value=None if code else value_from_wire(r.value),
                    descriptor=descriptor_from_wire(r.descriptor[0]) if r.descriptor else None,
                    code=code,
                    reason=r.reason,
                )
            )
        return GetReply(reply.node_id, reply.revision, tuple(results))

    def _finish_set(self, reply: Any) -> SetReply:
        self._check(reply)
        results = tuple(
            SetResult(r.name, r.successful, r.reason, ErrorCode(r.code) if r.code else None)
            for r in reply.results
        )
        return SetReply(reply.node_id, reply.revision, results)


class AsyncParameterClient:
    """The asyncio form of :class:`ParameterClient` (same calls, awaitable, pipelining-friendly)."""

    def __init__(self, client: ParameterClient) -> None:
        self.sync = client

    async def list(
        self, node: str, prefixes: Sequence[str] = (), depth: int = 0, *, timeout: float | None = None
    ) -> ListResult:
        c = self.sync
        return c._finish_list(await c._await(*c._send_list(node, prefixes, depth), timeout))

    async def get(
        self, node: str, names: Sequence[str], *, with_descriptors: bool = False, timeout: float | None = None
    ) -> GetReply:
        c = self.sync
        return c._finish_get(await c._await(*c._send_get(node, names, with_descriptors), timeout))

    async def set(
        self,
        node: str,
        params: ParamsArg,
        *,
        atomic: bool = False,
        if_revision: int | None = None,
        timeout: float | None = None,
    ) -> SetReply:
        c = self.sync
        return c._finish_set(await c._await(*c._send_set(node, params, atomic, if_revision), timeout))

    async def delete(self, node: str, names: Sequence[str], *, timeout: float | None = None) -> SetReply:
        return await self.set(node, [Parameter(n, NOT_SET) for n in names], timeout=timeout)

    async def wait_for_node(self, node: str, timeout: float | None = None) -> NodeInfo:
        return await asyncio.to_thread(self.sync.wait_for_node, node, timeout)
