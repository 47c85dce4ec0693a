"""``paramdds foxglove``: one monitor, one client and a WebSocket server in one process.

The socket is bound first (a busy port or a bad address is a usage error, ``--port 0``
picks a free one), then the monitor is made and given up to ``--timeout`` to hold the
current state, then the client; then the ready line is printed (:data:`READY`) and the
server serves until SIGINT or SIGTERM (exit 0). On the way out the connections are
closed, then the client, the monitor and the participant.
"""

from __future__ import annotations

import argparse
import asyncio
import signal
import socket
import sys

from websockets.asyncio.server import ServerConnection, serve
from websockets.http11 import Request, Response

from ..core.origin import Via
from ..exits import Exit
from ..listen import bind_socket
from ..session import Session
from .access import Access, access_for
from .protocol import SUBPROTOCOLS
from .server import FoxgloveServer

READY = "[FOXGLOVE] Foxglove WebSocket server on ws://{host}:{port} ({nodes})"
MAX_MESSAGE = 16 * 2**20  # bytes of one client message
CLOSE_TIMEOUT = 1.0  # seconds a client has to answer the closing handshake when the server stops


def run(args: argparse.Namespace) -> int:
    access = access_for(args.host, args.token_file)
    sock = bind_socket(args.host, args.port)
    try:
        asyncio.run(_serve(args, access, sock))
    finally:
        sock.close()
    return Exit.OK


async def _serve(args: argparse.Namespace, access: Access, sock: socket.socket) -> None:
    from ..dds.client import AsyncParameterClient

    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    server = FoxgloveServer(loop, access)
    session = Session(args, app_name="paramdds-foxglove")
    try:
        monitor = await asyncio.to_thread(session.monitor, args.nodes or None, server.on_event)
        await asyncio.to_thread(monitor.settle, args.timeout)
        client = AsyncParameterClient(session.client(Via.FOXGLOVE))
        server.attach(monitor, client)

        def refuse(connection: ServerConnection, request: Request) -> Response | None:
            why = server.authorize(request.path, request.headers)
            if why is None:
                return None
            return connection.respond(why[0], why[1])

        async with serve(
            server.handle,
            sock=sock,
            subprotocols=[*SUBPROTOCOLS],  # type: ignore[list-item]
            process_request=refuse,
            compression=None,
            close_timeout=CLOSE_TIMEOUT,
            max_size=MAX_MESSAGE,
            server_header="paramdds",
        ):
            if stop.is_set():  # stopped while starting: no ready line
                return
            name, port = sock.getsockname()[:2]
            shown = f"[{name}]" if ":" in name else name
            sys.stdout.write(READY.format(host=shown, port=port, nodes=_nodes(server.online_count())) + "\n")
            sys.stdout.flush()
            await stop.wait()
            await server.close()
    finally:
        await asyncio.to_thread(session.close)


def _nodes(count: int) -> str:
    return f"{count} node" if count == 1 else f"{count} nodes"
