"""The server's fan-out of monitor events, without sockets: what each connection is sent, and when."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.monitor_events import EventKind, MonitorEvent, NodeState
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.foxglove import protocol as p
from paramdds.foxglove.access import Access
from paramdds.foxglove.server import QUEUE_SIZE, Connection, FoxgloveServer

INT = ParameterType.INTEGER


def state(node: str, online: bool = True, **params: int) -> NodeState:
    st = NodeState(node, online=online, revision=1)
    for name, v in params.items():
        st.parameters[name] = (ParameterValue.of(INT, v), ParameterDescriptor(name, INT))
    return st


class Book:
    def __init__(self, *states: NodeState) -> None:
        self.states = {st.node: st for st in states}

    def wait_until(self, predicate: Any, timeout: float) -> bool:
        return bool(predicate(self.states))


class FakeSocket:
    closed_with: tuple[int, str] | None = None

    async def close(self, code: int, reason: str) -> None:
        self.closed_with = (code, reason)


def connection(server: FoxgloveServer) -> Connection:
    conn = Connection(FakeSocket(), None, True)  # type: ignore[arg-type]
    server._connections.add(conn)
    return conn


def sent(conn: Connection) -> list[Any]:
    out: list[Any] = []
    while not conn.queue.empty():
        item = conn.queue.get_nowait()
        for frame in item if isinstance(item, list) else [item]:
            out.append(json.loads(frame) if isinstance(frame, str) else json.loads(frame[13:]))
    return out


def event(kind: EventKind, node: str, name: str = "", value: int | None = None) -> MonitorEvent:
    return MonitorEvent(kind, node, name, ParameterValue.of(INT, value) if value is not None else None)


def run(book: Book, body: Any) -> None:
    async def go() -> None:
        server = FoxgloveServer(asyncio.get_running_loop(), Access())
        server.attach(book, None)  # type: ignore[arg-type]
        body(server)

    asyncio.run(go())


def test_changes_go_to_their_subscribers_only_and_coalesce() -> None:
    book = Book(state("arm", gain=4, mode=1), state("base", gain=4))

    def body(server: FoxgloveServer) -> None:
        every, one, none = connection(server), connection(server), connection(server)
        every.all_parameters = True
        one.parameters = {"/arm.gain"}
        for v in (5, 6):
            server.on_event(event(EventKind.MODIFIED, "arm", "gain", v))
        server.on_event(event(EventKind.MODIFIED, "base", "gain", 1))
        server._events.drain()
        assert sent(every) == [
            p.parameter_values([{"name": "/arm.gain", "value": 6}, {"name": "/base.gain", "value": 1}])
        ]
        assert sent(one) == [p.parameter_values([{"name": "/arm.gain", "value": 6}])]
        assert sent(none) == []

    run(book, body)


def test_an_offline_node_is_unset_and_a_node_coming_back_is_not_until_its_state_says_so() -> None:
    arm = state("arm", online=False, gain=4)
    book = Book(arm)

    def body(server: FoxgloveServer) -> None:
        conn = connection(server)
        conn.all_parameters = True
        server.on_event(event(EventKind.OFFLINE, "arm"))
        server._events.drain()
        assert sent(conn) == [p.parameter_values([{"name": "/arm.gain"}])]
        server.on_event(event(EventKind.RESTARTED, "arm"))  # while its state still says offline
        server._events.drain()
        assert sent(conn) == []
        arm.online = True
        server.on_event(event(EventKind.ONLINE, "arm"))
        server._events.drain()
        assert sent(conn) == [p.parameter_values([{"name": "/arm.gain", "value": 4}])]
        assert server.values(()) == [{"name": "/arm.gain", "value": 4}]
        arm.online = False
        assert server.values(()) == [] and server.values(["/arm.gain"]) == []

    run(book, body)


def test_the_channel_sends_every_online_node_on_subscribe_then_each_changed_node() -> None:
    book = Book(state("arm", gain=4), state("base", gain=2), state("gone", online=False, x=1))

    def body(server: FoxgloveServer) -> None:
        conn = connection(server)
        server._subscribe(conn, p.Subscribe(((9, p.CHANNEL_ID), (3, 42))))
        first = sent(conn)
        assert [m["node"] for m in first[:2]] == ["arm", "base"]
        assert first[2]["op"] == "status" and "no channel 42" in first[2]["message"]
        server.on_event(event(EventKind.MODIFIED, "base", "gain", 3))
        server._events.drain()
        (message,) = sent(conn)
        assert message["node"] == "base" and message["parameters"][0]["parameter"] == "gain"

    run(book, body)


def test_a_client_that_falls_behind_is_closed() -> None:
    book = Book(state("arm", gain=4))

    def body(server: FoxgloveServer) -> None:
        conn = connection(server)
        for _ in range(QUEUE_SIZE + 1):
            conn.send(p.status(p.INFO, "x"))
        assert conn.closed
        conn.send(p.status(p.INFO, "after"))  # ignored
        assert conn.queue.qsize() == QUEUE_SIZE

    run(book, body)
