"""`paramdds foxglove` end to end from Python: real nodes, a real server process, a WebSocket client.

The protocol as Foxglove's own client library speaks it is tested by tests/foxglove/test_ws_clients.py
(Node's @foxglove/ws-protocol); this is the server's smoke test: get, set, refusal, pushes,
a node going away, tokens, a client leaving mid-call, bad options.
"""

from __future__ import annotations

import asyncio
import json
import socket
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import InvalidStatus

from ..cli._support import Proc, next_domain, run_cli, start_server

ROOT = Path(__file__).resolve().parents[2]
PARAMS = str(ROOT / "examples" / "console_params.yaml")
READY = "[FOXGLOVE] Foxglove WebSocket server on ws://"
V1 = "foxglove.websocket.v1"


@pytest.fixture(scope="module")
def domain() -> int:
    return next_domain()


@pytest.fixture(scope="module")
def nodes(domain: int) -> Iterator[Proc]:
    proc = start_server(domain, "-n", "arm", "-n", "base", "-p", PARAMS)
    yield proc
    proc.stop()


def start_foxglove(domain: int, *args: str) -> tuple[Proc, str]:
    proc = Proc(domain, ["foxglove", "--port", "0", *args])
    line = proc.wait_for(READY, 30)
    return proc, line.split(" on ", 1)[1].split(" ", 1)[0]


@pytest.fixture(scope="module")
def fox(domain: int, nodes: Proc) -> Iterator[tuple[Proc, str]]:
    proc, url = start_foxglove(domain, "--timeout", "2")
    yield proc, url
    assert proc.stop() == 0


async def opened(url: str, protocol: str = V1) -> ClientConnection:
    ws = await connect(url, subprotocols=[protocol])  # type: ignore[list-item]
    info = json.loads(await ws.recv())
    assert info["op"] == "serverInfo" and {"parameters", "parametersSubscribe"} <= set(info["capabilities"])
    advertised = json.loads(await ws.recv())
    assert advertised["op"] == "advertise"
    return ws


async def ask(ws: ClientConnection, msg: dict[str, Any]) -> None:
    await ws.send(json.dumps(msg))


async def until(ws: ClientConnection, pred: Any, timeout: float = 10.0) -> Any:
    """The first message (JSON, or a binary frame as bytes) for which ``pred`` holds."""
    async with asyncio.timeout(timeout):
        while True:
            raw = await ws.recv()
            msg = json.loads(raw) if isinstance(raw, str) else raw
            if pred(msg):
                return msg


async def until_each(ws: ClientConnection, preds: dict[str, Any], timeout: float = 10.0) -> dict[str, Any]:
    """The first message for which each of ``preds`` holds, in whatever order they come."""
    found: dict[str, Any] = {}
    async with asyncio.timeout(timeout):
        while len(found) < len(preds):
            raw = await ws.recv()
            msg = json.loads(raw) if isinstance(raw, str) else raw
            found.update({key: msg for key, pred in preds.items() if key not in found and pred(msg)})
    return found


def replied(rid: str) -> Any:
    return lambda m: isinstance(m, dict) and m.get("op") == "parameterValues" and m.get("id") == rid


def status_of(rid: str) -> Any:
    return lambda m: isinstance(m, dict) and m.get("op") == "status" and m.get("id") == rid


def pushed(name: str) -> Any:
    return lambda m: (
        isinstance(m, dict)
        and m.get("op") == "parameterValues"
        and "id" not in m
        and any(p["name"] == name for p in m["parameters"])
    )


def run(coro: Any) -> Any:
    return asyncio.run(coro)


def test_the_ready_line_and_both_subprotocols(fox: tuple[Proc, str]) -> None:
    proc, url = fox
    assert proc.lines[-1].endswith("(2 nodes)")

    async def go() -> None:
        for protocol in ("foxglove.websocket.v1", "foxglove.sdk.v1"):
            ws = await opened(url, protocol)
            assert ws.subprotocol == protocol
            await ask(ws, {"op": "getParameters", "parameterNames": [], "id": "all"})
            got = await until(ws, replied("all"))
            by_name = {p["name"]: p for p in got["parameters"]}
            assert len(by_name) == 18
            assert by_name["/arm.limits"] == {
                "name": "/arm.limits",
                "value": [0.5, 1.0, 2.0],
                "type": "float64_array",
            }
            assert by_name["/base.key"] == {"name": "/base.key", "value": "AQKr", "type": "byte_array"}
            assert by_name["/base.gain"] == {"name": "/base.gain", "value": 4}
            await ask(
                ws, {"op": "getParameters", "parameterNames": ["/arm.mode", "/arm.nope", "bad"], "id": "2"}
            )
            assert (await until(ws, replied("2")))["parameters"] == [{"name": "/arm.mode", "value": "auto"}]
            await ws.close()
        with pytest.raises(InvalidStatus, match="400"):
            await connect(url, subprotocols=["another.v1"])  # type: ignore[list-item]

    run(go())


def test_sets_refusals_and_changes_made_elsewhere(domain: int, fox: tuple[Proc, str]) -> None:
    _, url = fox

    async def go() -> None:
        ws = await opened(url)
        watcher = await opened(url, "foxglove.sdk.v1")
        await ask(watcher, {"op": "subscribeParameterUpdates", "parameterNames": ["/arm.note", "/base.gain"]})
        await ask(ws, {"op": "subscribeParameterUpdates", "parameterNames": []})
        await ask(ws, {"op": "getParameters", "parameterNames": [], "id": "sync"})  # after the subscribe
        await until(ws, replied("sync"))
        # one set across two nodes: one request per node
        await ask(
            ws,
            {
                "op": "setParameters",
                "id": "s1",
                "parameters": [
                    {"name": "/arm.note", "value": "from fox"},
                    {"name": "/base.gain", "value": 6},
                ],
            },
        )
        got = await until(ws, replied("s1"))
        assert sorted(got["parameters"], key=lambda p: p["name"]) == [
            {"name": "/arm.note", "value": "from fox"},
            {"name": "/base.gain", "value": 6},
        ]
        seen: dict[str, Any] = {}
        while len(seen) < 2:
            msg = await until(watcher, lambda m: m.get("op") == "parameterValues")
            seen.update({p["name"]: p.get("value") for p in msg["parameters"]})
        assert seen == {"/arm.note": "from fox", "/base.gain": 6}
        # refused by the node: its current value and a warning with its reason and the request id
        await ask(
            ws,
            {
                "op": "setParameters",
                "id": "s2",
                "parameters": [{"name": "/arm.speed", "value": 9.0, "type": "float64"}],
            },
        )
        warned = await until(ws, status_of("s2"))
        assert warned["level"] == 1 and "must be within [0.0, 5.0]" in warned["message"]
        assert (await until(ws, replied("s2")))["parameters"] == [
            {"name": "/arm.speed", "value": 1.5, "type": "float64"}
        ]
        # a node that does not exist: an error, same shape
        await ask(ws, {"op": "setParameters", "id": "s3", "parameters": [{"name": "/ghost.x", "value": 1}]})
        failed = await until(ws, status_of("s3"))
        assert failed["level"] == 2 and "ghost" in failed["message"]
        assert (await until(ws, replied("s3")))["parameters"] == [{"name": "/ghost.x"}]
        # a value that is no parameter value
        await ask(
            ws, {"op": "setParameters", "id": "s4", "parameters": [{"name": "/arm.note", "value": {"a": 1}}]}
        )
        assert "nested object" in (await until(ws, status_of("s4")))["message"]
        # a change made by the CLI reaches the subscriber (how fast: tests/foxglove/test_ws_clients.py)
        done = asyncio.create_task(asyncio.to_thread(run_cli, domain, "set", "arm", "gain", "7"))
        change = await until(ws, pushed("/arm.gain"), timeout=10)
        assert {"name": "/arm.gain", "value": 7} in change["parameters"]
        finished = await done
        assert finished.returncode == 0, (finished.returncode, finished.stdout, finished.stderr)
        await ws.close()
        await watcher.close()

    run(go())
    history = run_cli(domain, "history", "arm", "note", "-o", "json")
    assert '"via": "foxglove"' in history.stdout, history


def test_descriptors_and_blame_on_the_channel(fox: tuple[Proc, str]) -> None:
    _, url = fox

    async def go() -> None:
        ws = await opened(url)
        await ask(ws, {"op": "subscribe", "subscriptions": [{"id": 5, "channelId": 1}]})
        frames = [await until(ws, lambda m: isinstance(m, bytes)) for _ in range(2)]
        messages = {}
        for frame in frames:
            op, sub, _stamp = struct.unpack_from("<BIQ", frame)
            assert (op, sub) == (1, 5)
            body = json.loads(frame[13:])
            messages[body["node"]] = body
        speed = next(p for p in messages["arm"]["parameters"] if p["parameter"] == "speed")
        assert speed["descriptor"]["description"] == "Top speed in m/s"
        assert speed["type"] == "double" and speed["last_change"]["revision"] >= 1
        await ask(ws, {"op": "setParameters", "parameters": [{"name": "/base.mode", "value": "manual"}]})
        body = json.loads((await until(ws, lambda m: isinstance(m, bytes)))[13:])
        mode = next(p for p in body["parameters"] if p["parameter"] == "mode")
        assert (
            body["node"] == "base" and mode["value"] == "manual" and mode["last_change"]["via"] == "foxglove"
        )
        await ws.close()

    run(go())


def test_a_client_leaving_mid_call_harms_nobody(fox: tuple[Proc, str]) -> None:
    _, url = fox

    async def go() -> None:
        leaving = await opened(url)
        await ask(
            leaving,
            {"op": "setParameters", "id": "x", "parameters": [{"name": "/arm.tags", "value": ["mid"]}]},
        )
        await ask(leaving, {"op": "getParameters", "parameterNames": [], "id": "y"})
        await asyncio.sleep(0.05)  # read by the server (a reset drops what it has not read yet)
        leaving.transport.abort()  # gone mid-call, without a close handshake
        ws = await opened(url)
        await asyncio.sleep(0.5)
        await ask(ws, {"op": "getParameters", "parameterNames": ["/arm.tags"], "id": "z"})
        assert (await until(ws, replied("z")))["parameters"] == [{"name": "/arm.tags", "value": ["mid"]}]
        await ws.close()

    run(go())


def test_an_offline_node_is_unset_and_comes_back(domain: int, nodes: Proc) -> None:
    extra = start_server(domain, "-n", "cart", "-p", PARAMS)
    proc, url = start_foxglove(domain, "--timeout", "2", "cart", "arm")
    assert proc.lines[-1].endswith("(2 nodes)")  # the globs given: cart and arm, not base

    async def go() -> None:
        ws = await opened(url)
        await ask(ws, {"op": "subscribeParameterUpdates", "parameterNames": ["/cart.gain", "/cart.mode"]})
        await ask(ws, {"op": "getParameters", "parameterNames": [], "id": "a"})
        assert len((await until(ws, replied("a")))["parameters"]) == 18
        extra.popen.kill()
        gone = await until(ws, pushed("/cart.gain"), timeout=20)
        assert {"name": "/cart.gain"} in gone["parameters"]
        await ask(ws, {"op": "getParameters", "parameterNames": [], "id": "b"})
        left = (await until(ws, replied("b")))["parameters"]
        assert len(left) == 9 and not any(p["name"].startswith("/cart.") for p in left)
        back = await asyncio.to_thread(start_server, domain, "-n", "cart", "-p", PARAMS)
        came = await until(ws, pushed("/cart.gain"), timeout=20)  # no unset first: a restart is no offline
        assert {"name": "/cart.gain", "value": 4} in came["parameters"]
        await ws.close()
        back.stop()

    try:
        run(go())
    finally:
        extra.stop()
        assert proc.stop() == 0


def test_tokens(domain: int, nodes: Proc, tmp_path: Path) -> None:
    tokens = tmp_path / "tokens"
    tokens.write_text("carol 0123456789abcdef\n")
    proc, url = start_foxglove(domain, "--token-file", str(tokens))

    async def go() -> None:
        ws = await opened(url)  # on loopback anyone connects; a set needs the token
        await ask(
            ws, {"op": "setParameters", "id": "t1", "parameters": [{"name": "/arm.note", "value": "nope"}]}
        )
        assert "need the token" in (await until(ws, status_of("t1")))["message"]
        await ws.close()
        ws = await opened(url + "?token=0123456789abcdef")
        await ask(
            ws,
            {"op": "setParameters", "id": "t2", "parameters": [{"name": "/arm.note", "value": "by carol"}]},
        )
        assert (await until(ws, replied("t2")))["parameters"] == [{"name": "/arm.note", "value": "by carol"}]
        await ws.close()

    try:
        run(go())
    finally:
        assert proc.stop() == 0
    described = run_cli(domain, "history", "arm", "note", "-o", "json")
    assert '"who": "carol"' in described.stdout, described


def test_bad_options_are_usage_errors(domain: int) -> None:
    for args, why in (
        (["--port", "70000"], "--port"),
        (["--host", "0.0.0.0"], "--token-file"),
        (["--host", "127.0.0.1", "--token-file", "/nonexistent"], "--token-file"),
        (["not a node!"], "node"),
    ):
        done = run_cli(domain, "foxglove", *args, timeout=30)
        assert done.returncode == 2, (args, done)
        assert why in done.stderr and "Traceback" not in done.stderr, done.stderr
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        done = run_cli(domain, "foxglove", "--port", str(busy.getsockname()[1]), timeout=30)
        assert done.returncode == 2 and "cannot listen" in done.stderr, done


def test_beyond_loopback_every_connection_needs_the_token(domain: int, nodes: Proc, tmp_path: Path) -> None:
    tokens = tmp_path / "tokens"
    tokens.write_text("0123456789abcdef\n")
    proc, url = start_foxglove(domain, "--host", "0.0.0.0", "--token-file", str(tokens))
    assert url.startswith("ws://0.0.0.0:")
    url = url.replace("0.0.0.0", "127.0.0.1")

    async def go() -> None:
        for given in ("", "?token=wrong-token-0000000"):
            with pytest.raises(InvalidStatus, match="401"):
                await connect(url + given, subprotocols=[V1])  # type: ignore[list-item]
        ws = await opened(url + "?token=0123456789abcdef")
        await ws.close()
        ws = await connect(
            url, subprotocols=[V1], additional_headers={"Authorization": "Bearer 0123456789abcdef"}
        )  # type: ignore[list-item]
        await ws.close()

    try:
        run(go())
    finally:
        assert proc.stop() == 0


def test_on_loopback_a_foreign_host_name_is_refused(fox: tuple[Proc, str]) -> None:
    """A page whose DNS name rebinds to 127.0.0.1 sends its own name as Host: refused (403)."""
    _, url = fox
    port = int(url.rsplit(":", 1)[1].strip("/"))
    for host, status in (("evil.example", b" 403 "), (f"localhost:{port}", b" 101 ")):
        with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
            s.sendall(
                f"GET / HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                f"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                f"Sec-WebSocket-Protocol: {V1}\r\n\r\n".encode()
            )
            assert status in s.recv(200), host
