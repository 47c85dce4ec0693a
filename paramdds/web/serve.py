"""``paramdds web``: one monitor, one client and uvicorn in one process.

The socket is bound before anything else (a busy port or a bad address is a
usage error, and ``--bind HOST:0`` picks a free port), then the monitor and the
client are made, then the URL is printed and uvicorn serves until SIGINT or
SIGTERM. On the way out the event streams are ended first (uvicorn would wait
for them), then the client, the monitor and the participant are closed.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import ipaddress
import json
import socket
import sys
from collections.abc import Sequence

import h11
import uvicorn
from uvicorn.protocols.http.h11_impl import H11Protocol

from ..core.origin import Via
from ..exits import Exit, UsageError
from ..listen import LOOPBACK_NAMES, bind_socket, is_loopback, read_tokens
from ..session import Session
from .app import WebOptions, build_app
from .guard import SECURITY_HEADERS
from .hub import Hub
from .status import WebCode, error_body
from .view import StateView

DEFAULT_BIND = "127.0.0.1:8800"


def parse_bind(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``[::1]:PORT`` for IPv6) → (host, port); UsageError when malformed."""
    host, sep, port_text = text.rpartition(":")
    if not sep or not host:
        raise UsageError(f"--bind expects HOST:PORT, got {text!r}")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    try:
        port = int(port_text)
    except ValueError:
        raise UsageError(f"--bind: the port must be a number, got {port_text!r}") from None
    if not 0 <= port <= 65535:
        raise UsageError(f"--bind: the port must be within [0, 65535], got {port}")
    return host, port


class JsonH11Protocol(H11Protocol):
    """uvicorn's HTTP/1.1 protocol, answering a request it cannot parse (an HTTP/1.1
    request without ``Host``, a malformed request line) with the console's JSON error body
    and headers instead of uvicorn's plain text: such a request never reaches the app."""

    def send_400_response(self, msg: str) -> None:
        why = f"not a valid HTTP/1.1 request (a Host header is required): {msg}"
        body = json.dumps(error_body(WebCode.BAD_REQUEST.value, why)).encode()
        headers = [
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode()),
            (b"connection", b"close"),
            *SECURITY_HEADERS,
        ]
        response = h11.Response(status_code=400, headers=headers)
        for event in (response, h11.Data(data=body), h11.EndOfMessage()):
            self.transport.write(self.conn.send(event) or b"")
        self.transport.close()


class _Server(uvicorn.Server):
    """uvicorn, ending our event streams before it waits for open connections."""

    def __init__(self, config: uvicorn.Config, hub: Hub) -> None:
        super().__init__(config)
        self._hub = hub

    async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
        self._hub.close()
        await super().shutdown(sockets)


def options_from(args: argparse.Namespace, host: str) -> WebOptions:
    """The console's options; on a bind other machines can reach, a token is required (for
    reads as well as writes) and the ``Host`` check names the bind address and ``--allow-host``."""
    tokens = read_tokens(args.token_file) if args.token_file else ()
    loopback = is_loopback(host)
    extra = tuple(getattr(args, "allow_host", None) or ())
    if not loopback and not tokens:
        raise UsageError(
            f"--bind {host} is reachable from other machines: give --token-file "
            "(there the token is needed to read as well as to write)"
        )
    allowed = (*LOOPBACK_NAMES, host, *extra) if loopback else (*served_names(host), *extra)
    return WebOptions(
        read_only=args.read_only,
        tokens=tokens,
        domain=args.domain,
        zenoh=getattr(args, "zenoh", None),
        allowed_hosts=tuple(dict.fromkeys(h.lower() for h in allowed)),
        timeout=args.timeout,
        token_for_reads=not loopback,
        schemas=_schemas(getattr(args, "schema", None) or ()),
    )


def _schemas(given: Sequence[str]) -> tuple[tuple[str, object], ...]:
    """``--schema NODE=FILE`` values, each schema loaded (a bad one: exit 2 naming it)."""
    from ..core.names import canonical_node_id
    from ..errors import InvalidNameError
    from ..formats.schema import load_schema

    out = []
    for text in given:
        node, sep, path = text.partition("=")
        if not sep or not node or not path:
            raise UsageError(f"--schema takes NODE=FILE, got {text!r}")
        try:
            out.append((canonical_node_id(node), load_schema(path)))
        except InvalidNameError as exc:
            raise UsageError(f"--schema {text}: {exc.message}") from exc
    return tuple(out)


def served_names(host: str) -> tuple[str, ...]:
    """The names a browser may reach a non-loopback bind under: the bind address itself; for a
    wildcard bind (``0.0.0.0``, ``::``) this machine's name, its FQDN and their addresses, and
    the loopback names. Other names (a DNS alias, a proxy's) are given with ``--allow-host``."""
    try:
        wildcard = ipaddress.ip_address(host).is_unspecified
    except ValueError:
        wildcard = False
    if not wildcard:
        return (host,)
    names = [*LOOPBACK_NAMES, socket.gethostname(), socket.getfqdn()]
    for name in names[-2:]:
        with contextlib.suppress(OSError):  # a name that does not resolve here: the others hold
            names += [str(info[4][0]) for info in socket.getaddrinfo(name, None)]
    return tuple(names)


def run_web(args: argparse.Namespace) -> int:
    host, port = parse_bind(args.bind)
    options = options_from(args, host)
    sock = bind_socket(host, port)
    try:
        asyncio.run(_serve(args, options, sock))
    finally:
        sock.close()
    return Exit.OK


async def _serve(args: argparse.Namespace, options: WebOptions, sock: socket.socket) -> None:
    from ..dds.client import AsyncParameterClient

    loop = asyncio.get_running_loop()
    view = StateView()
    hub = Hub(view, loop)
    session = Session(args, app_name="paramdds-web")
    try:
        monitor = session.monitor(on_event=hub.on_event)
        view.attach(monitor, session.missing_sites if options.zenoh else None)
        if options.zenoh:  # the sites lacking are rows of the node list (view.lacking)
            hub.follow_sites()
        client = AsyncParameterClient(session.client(Via.WEB))
        app = build_app(view, hub, client, options)
        config = uvicorn.Config(
            app,
            log_level=args.log_level,
            access_log=False,
            lifespan="off",
            timeout_graceful_shutdown=2,
            http=JsonH11Protocol,
        )
        server = _Server(config, hub)
        name, port = sock.getsockname()[:2]
        shown = f"[{name}]" if ":" in name else name
        mode = (
            "read-only"
            if options.read_only
            else ("writes need the token" if options.tokens else "writes allowed")
        )
        where = f"zenoh {options.zenoh}" if options.zenoh else f"domain {args.domain}"
        sys.stdout.write(f"[WEB] Console on http://{shown}:{port}/ ({where}, {mode})\n")
        sys.stdout.flush()
        await server.serve(sockets=[sock])
    finally:
        await asyncio.to_thread(session.close)
