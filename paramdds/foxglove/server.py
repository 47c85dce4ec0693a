"""The Foxglove WebSocket server's connections: gets from the monitor, sets through the client, pushes.

One :class:`FoxgloveServer` serves every connection on the event loop. A get is answered
from the monitor's state (an empty one with every parameter of every online node, in one
reply). A set is sent as one atomic request per node through the client; its answer is
the values set, or the node's current values with a ``status`` saying why (level 1 when
the node refused, level 2 when the set did not reach it). The monitor's events arrive on
its own thread (:meth:`FoxgloveServer.on_event`); a burst is turned on the loop into one
``parameterValues`` per subscribed connection, and one message per changed node on the
descriptors channel. An offline node's parameters are published without a value, and
left out of gets until it is back.

Each connection has its own queue of outgoing messages and a task that writes them, so a
slow client delays nobody else; one that falls :data:`QUEUE_SIZE` messages behind is
closed (it reconnects and reads the state again). A connection that goes away while its
set is in flight loses only its answer.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple, Protocol

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed

from ..core.descriptors import ParameterDescriptor
from ..core.monitor_events import EventKind, MonitorEvent, NodeState
from ..core.values import Parameter, ParameterType, ParameterValue
from ..errors import ParamddsError
from ..listen import Handover, Token, matching
from . import protocol as p
from .access import Access, given_token, host_name
from .names import BadValue, foxglove_name, from_foxglove, split_name, to_foxglove

if TYPE_CHECKING:
    from ..core.replies import SetReply
    from ..core.request import ParamsArg

log = logging.getLogger(__name__)

TOKEN_URL = "ws://HOST:PORT/?token=TOKEN"
QUEUE_SIZE = 1024  # outgoing messages a connection may fall behind by
CATCH_UP = 2.0  # seconds a set's echo waits for the monitor to hold what was set
Entry = dict[str, object]  # one parameter of a parameterValues message
Table = dict[str, tuple[ParameterValue, ParameterDescriptor]]


class Held(NamedTuple):
    """What the monitor holds of a node, read under its lock: presence, revision, a copy of its table,
    and its state (read afterwards for the last changes alone)."""

    online: bool
    revision: int
    table: Table
    state: NodeState


class States(Protocol):
    """What the server reads of a monitor: its live state, under its lock."""

    def wait_until(self, predicate: Callable[[dict[str, NodeState]], bool], timeout: float) -> bool: ...


class Setter(Protocol):
    """What the server sets through: :class:`~paramdds.dds.client.AsyncParameterClient`'s ``set``."""

    async def set(
        self, node: str, params: ParamsArg, *, atomic: bool = False, as_: str | None = None
    ) -> SetReply: ...


@dataclass(eq=False)
class Connection:
    ws: ServerConnection
    token: Token | None
    may_set: bool
    all_parameters: bool = False  # subscribed to every parameter
    parameters: set[str] = field(default_factory=set)  # subscribed names
    channels: dict[int, int] = field(default_factory=dict)  # subscription id -> channel id
    # each item is a message, or a batch of them (one node's message each, on the channel)
    queue: asyncio.Queue[str | bytes | list[bytes] | None] = field(
        default_factory=lambda: asyncio.Queue(QUEUE_SIZE)
    )
    closed: bool = False

    def send(self, message: str | bytes | list[bytes] | Mapping[str, object]) -> None:
        if self.closed:
            return
        data = message if isinstance(message, (str, bytes, list)) else p.dumps(message)
        try:
            self.queue.put_nowait(data)
        except asyncio.QueueFull:  # too slow: closed, it reconnects and reads the state again
            self.close()
            asyncio.get_running_loop().create_task(self.ws.close(1008, "too slow: reconnect"))

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            with contextlib.suppress(asyncio.QueueFull):
                self.queue.put_nowait(None)

    def wants(self, name: str) -> bool:
        return self.all_parameters or name in self.parameters

    async def write(self) -> None:
        while (data := await self.queue.get()) is not None:
            try:
                for frame in data if isinstance(data, list) else [data]:
                    await self.ws.send(frame)
            except ConnectionClosed:
                return


class FoxgloveServer:
    """Every connection's requests and pushes (see the module's doc)."""

    def __init__(self, loop: asyncio.AbstractEventLoop, access: Access, name: str = "paramdds") -> None:
        self._loop = loop
        self._access = access
        self._name = name
        self._session_id = str(time.time_ns())
        self._states: States | None = None
        self._setter: Setter | None = None
        self._connections: set[Connection] = set()
        self._tasks: set[asyncio.Task[None]] = set()
        self._events = Handover(loop, self._flush)

    def attach(self, states: States, setter: Setter) -> None:
        """Serve ``states`` (the monitor, made after this server, which receives its events) and
        set through ``setter``."""
        self._states, self._setter = states, setter

    # -- reading the monitor ----------------------------------------------------------------

    def _peek(self, fn: Callable[[dict[str, NodeState]], object]) -> None:
        def run(states: dict[str, NodeState]) -> bool:
            fn(states)
            return True

        if self._states is not None:
            self._states.wait_until(run, 0.0)

    def _tables(self, nodes: Iterable[str] | None) -> dict[str, Held]:
        """What the monitor holds of ``nodes`` (None: every one), read under its lock."""
        out: dict[str, Held] = {}

        def take(states: dict[str, NodeState]) -> None:
            for node in states if nodes is None else nodes:
                st = states.get(node)
                if st is not None:
                    out[node] = Held(st.online, st.revision, dict(st.parameters), st)

        self._peek(take)
        return out

    def online_count(self) -> int:
        counted: list[int] = []
        self._peek(lambda states: counted.append(sum(st.online for st in states.values())))
        return counted[0] if counted else 0

    def values(self, names: Sequence[str]) -> list[Entry]:
        """``getParameters``: every online node's parameters (``names`` empty), or those named that an
        online node has (the others are left out, as foxglove_bridge does)."""
        if not names:
            out: list[Entry] = []
            for node, held in self._tables(None).items():
                if held.online:
                    out += [to_foxglove(foxglove_name(node, n), v) for n, (v, _d) in held.table.items()]
            return out
        wanted: dict[str, list[tuple[str, str]]] = {}
        for full in dict.fromkeys(names):
            split = split_name(full)
            if split is not None:
                wanted.setdefault(split[0], []).append((full, split[1]))
        tables = self._tables(wanted)
        found: list[Entry] = []
        for node, asked in wanted.items():
            named = tables.get(node)
            if named is not None and named.online:
                table = named.table
                found += [to_foxglove(full, table[n][0]) for full, n in asked if n in table]
        return found

    # -- the monitor's side (its thread) ----------------------------------------------------

    def on_event(self, event: MonitorEvent) -> None:
        self._events.put(event)

    # -- the event loop's side --------------------------------------------------------------

    def _flush(self, events: list[MonitorEvent]) -> None:
        if not self._connections:
            return
        updates: dict[str, Entry] = {}
        # nodes that came, went or restarted (each one's last such event): published as the state
        # says, once it says the same (a restart's events arrive while its state is being updated)
        reread: dict[str, EventKind] = {}
        changed: dict[str, None] = {}
        for e in events:
            if not e.node:
                continue
            changed[e.node] = None
            if e.event in (EventKind.ONLINE, EventKind.OFFLINE, EventKind.RESTARTED):
                reread[e.node] = e.event
            elif e.event in (EventKind.ADDED, EventKind.MODIFIED) and e.name:
                full = foxglove_name(e.node, e.name)
                updates[full] = to_foxglove(full, e.value)
            elif e.event is EventKind.DELETED and e.name:
                full = foxglove_name(e.node, e.name)
                updates[full] = {"name": full}
        tables = self._tables(changed)
        for node, kind in reread.items():
            held = tables.get(node)
            if held is None or held.online is (kind is EventKind.OFFLINE):
                continue
            online, table = held.online, held.table
            for n, (v, _d) in table.items():
                full = foxglove_name(node, n)
                updates[full] = to_foxglove(full, v if online else None)
        if updates:
            for conn in list(self._connections):
                mine = [u for name, u in updates.items() if conn.wants(name)]
                if mine:
                    conn.send(p.parameter_values(mine))
        subscriptions = self._channel_subscriptions()
        if subscriptions:
            payloads = [_node_payload(node, tables[node]) for node in changed if node in tables]
            now = time.time_ns()
            for conn, sub in subscriptions:
                conn.send([p.message_data(sub, now, payload) for payload in payloads])

    def _channel_subscriptions(self) -> list[tuple[Connection, int]]:
        return [
            (conn, sub)
            for conn in self._connections
            for sub, ch in conn.channels.items()
            if ch == p.CHANNEL_ID
        ]

    # -- a connection -----------------------------------------------------------------------

    def authorize(self, path: str, headers: Mapping[str, str]) -> tuple[int, str] | None:
        """Why a handshake is refused (HTTP status, text), or None to accept it."""
        host = headers.get("Host", "")
        if self._access.hosts and host_name(host) not in self._access.hosts:
            return 403, f"unexpected Host {host[:100]!r}\n"
        token = matching(self._access.tokens, given_token(path, headers))
        if self._access.token_to_connect and token is None:
            return 401, f"a token is required: connect to {TOKEN_URL}\n"
        return None

    async def handle(self, ws: ServerConnection) -> None:
        request = ws.request
        token = None
        if request is not None and self._access.tokens:
            token = matching(self._access.tokens, given_token(request.path, request.headers))
        conn = Connection(ws, token, self._access.may_set(token))
        self._connections.add(conn)
        writer = asyncio.create_task(conn.write())
        conn.send(p.server_info(self._name, self._session_id, {"paramdds": "parameters of every node"}))
        conn.send(p.advertise())
        try:
            async for message in ws:
                if conn.closed:
                    break
                if isinstance(message, bytes):
                    conn.send(p.status(p.ERROR, "binary client messages are not offered by this server"))
                    continue
                try:
                    op = p.parse(message)
                except p.ProtocolError as exc:
                    conn.send(p.status(p.ERROR, str(exc)))
                    continue
                await self._dispatch(conn, op)
        except ConnectionClosed:
            pass
        finally:
            self._connections.discard(conn)
            conn.close()
            await writer

    async def _dispatch(self, conn: Connection, op: p.Op) -> None:
        if isinstance(op, p.GetParameters):
            found = await asyncio.to_thread(self._encoded_values, op.names, op.id)
            conn.send(found)
        elif isinstance(op, p.SetParameters):
            task = asyncio.create_task(self._set(conn, op))  # a slow node delays no other request
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)
        elif isinstance(op, p.SubscribeParameters):
            if op.names:
                conn.parameters.update(op.names)
            else:
                conn.all_parameters = True
        elif isinstance(op, p.UnsubscribeParameters):
            if op.names:
                conn.parameters.difference_update(op.names)
            else:
                conn.all_parameters = False
                conn.parameters.clear()
        elif isinstance(op, p.Subscribe):
            self._subscribe(conn, op)
        else:
            for sub in op.ids:
                conn.channels.pop(sub, None)

    def _encoded_values(self, names: Sequence[str], rid: str | None) -> str:
        return p.dumps(p.parameter_values(self.values(names), rid))

    def _subscribe(self, conn: Connection, op: p.Subscribe) -> None:
        for sub, channel in op.subscriptions:
            if channel != p.CHANNEL_ID:
                known = f"the one channel is {p.CHANNEL_ID}, {p.TOPIC}"
                conn.send(p.status(p.ERROR, f"no channel {channel} ({known})"))
                continue
            if sub in conn.channels:
                conn.send(p.status(p.ERROR, f"subscription id {sub} is already in use"))
                continue
            conn.channels[sub] = channel
            now = time.time_ns()
            online = sorted((node, held) for node, held in self._tables(None).items() if held.online)
            conn.send([p.message_data(sub, now, _node_payload(node, held)) for node, held in online])

    # -- sets -------------------------------------------------------------------------------

    async def _set(self, conn: Connection, op: p.SetParameters) -> None:
        try:
            echoed = await self._set_all(conn, op)
        except Exception as exc:  # a bug must not take the server down; the client hears of it
            log.exception("set failed")
            conn.send(p.status(p.ERROR, f"set failed: {exc}", op.id))
            return
        if op.id is not None or echoed:
            conn.send(p.parameter_values(echoed, op.id))

    async def _set_all(self, conn: Connection, op: p.SetParameters) -> list[Entry]:
        """The entries a set answers with: the values set, or each refused node's current ones."""
        by_node: dict[str, list[tuple[str, str, Mapping[str, object]]]] = {}
        for entry in op.parameters:
            full = str(entry["name"])
            split = split_name(full)
            if split is None:
                why = f"{full[:200]!r} is not a paramdds parameter (/<node>.<param>)"
                conn.send(p.status(p.ERROR, why, op.id))
                continue
            by_node.setdefault(split[0], []).append((full, split[1], entry))
        if not by_node:
            return []
        if not conn.may_set:
            conn.send(p.status(p.ERROR, f"sets need the token: connect to {TOKEN_URL}", op.id))
            return self._current(by_node)
        tables = self._tables(by_node)
        results = await asyncio.gather(
            *(self._set_node(conn, node, items, tables.get(node), op.id) for node, items in by_node.items())
        )
        return [entry for entries in results for entry in entries]

    def _current(self, by_node: Mapping[str, Sequence[tuple[str, str, object]]]) -> list[Entry]:
        """The values nodes hold now for ``by_node``'s names (unset: an offline node's, or none's)."""
        tables = self._tables(by_node)
        out: list[Entry] = []
        for node, items in by_node.items():
            held = tables.get(node)
            online, table = (held.online, held.table) if held is not None else (False, {})
            out += [to_foxglove(full, table[n][0] if online and n in table else None) for full, n, _ in items]
        return out

    async def _set_node(
        self,
        conn: Connection,
        node: str,
        items: list[tuple[str, str, Mapping[str, object]]],
        held: Held | None,
        rid: str | None,
    ) -> list[Entry]:
        table = held.table if held is not None else {}
        params: list[Parameter] = []
        for _full, name, entry in items:
            current: ParameterType | None = table[name][0].type if name in table else None
            try:
                params.append(Parameter(name, from_foxglove(entry, current)))
            except BadValue as exc:
                conn.send(p.status(p.WARNING, f"{node} was not asked: {name}: {exc.message}{_req(rid)}", rid))
                return self._current({node: items})
        assert self._setter is not None
        who = conn.token.name if conn.token is not None and conn.token.name else None
        try:
            reply = await self._setter.set(node, params, atomic=True, as_=who)
        except ParamddsError as exc:  # the node is unknown, gone, or did not answer in time
            conn.send(p.status(p.ERROR, f"the set did not reach {node}: {exc.message}{_req(rid)}", rid))
            return self._current({node: items})
        if not reply.successful:
            reasons = "; ".join(f"{r.name}: {r.reason or r.code}" for r in reply.results if not r.successful)
            conn.send(p.status(p.WARNING, f"{node} refused the set: {reasons}{_req(rid)}", rid))
            return self._current({node: items})
        # a node publishes its new values just after its reply: the echo waits (bounded) until the
        # monitor holds them, so that a get made after it reads what was set
        await asyncio.to_thread(self._wait_held, node, params, reply.revision)
        return [to_foxglove(full, param.value) for (full, _n, _e), param in zip(items, params, strict=True)]

    def _wait_held(self, node: str, params: Sequence[Parameter], revision: int) -> bool:
        """Wait up to :data:`CATCH_UP` seconds until the monitor holds ``params`` on ``node`` (each
        value, or a later change of it than ``revision``)."""

        def held(states: dict[str, NodeState]) -> bool:
            st = states.get(node)
            if st is None:
                return False
            for param in params:
                entry = st.parameters.get(param.name)
                blame = st.blame.get(param.name)
                if not (entry is not None and entry[0].same_as(param.value)) and not (
                    blame is not None and blame[4] > revision
                ):
                    return False
            return True

        return self._states is None or self._states.wait_until(held, CATCH_UP)

    async def close(self) -> None:
        """Stop taking events and end every connection's writer."""
        self._events.close()
        for conn in list(self._connections):
            conn.close()
        for task in list(self._tasks):
            task.cancel()


def _node_payload(node: str, held: Held) -> bytes:
    """One node's message on the descriptors channel, as JSON bytes."""
    last = {n: lc for n in held.table if (lc := held.state.last_change(n)) is not None}
    revision = max([held.revision, *(lc.revision for lc in last.values())])
    message = p.node_message(node, held.online, revision, held.table, last)
    return json.dumps(message, allow_nan=False, separators=(",", ":")).encode()


def _req(rid: str | None) -> str:
    return f" (request {rid})" if rid is not None else ""
