"""Who may connect and who may set: the listening socket, the tokens, and the ``Host`` check.

The rules are the web console's (docs/web.md): a loopback bind serves anyone on this
machine; a bind other machines can reach needs ``--token-file``, and there every
connection must carry a token. With a token file on loopback, connecting is free but a set
needs the token. The token file holds one token (a word of 16+ characters) or ``NAME
TOKEN`` per line; a set made with a named token is recorded as made by NAME.

A browser's WebSocket cannot send headers, so the token comes as ``?token=...`` in the
URL (``ws://HOST:PORT/?token=...``) or, from other clients, as ``Authorization: Bearer
...``. On loopback the ``Host`` header must name this machine (a page on another site that
rebinds its DNS name to 127.0.0.1 is refused).
"""

from __future__ import annotations

import hmac
import ipaddress
import socket
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from ..exits import UsageError

MIN_TOKEN = 16  # characters
MAX_NAME = 100  # characters of an operator's name
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")


@dataclass(frozen=True)
class Token:
    """A token the server accepts, and the operator it names ("": none)."""

    secret: str
    name: str = ""


@dataclass(frozen=True)
class Access:
    """What a bind requires: its tokens, whether connecting needs one, the names it is reached by."""

    tokens: tuple[Token, ...] = ()
    token_to_connect: bool = False
    hosts: tuple[str, ...] = ()  # Host header names accepted (empty: any)

    def may_set(self, token: Token | None) -> bool:
        return token is not None or not self.tokens


def parse_tokens(text: str) -> tuple[Token, ...]:
    """The tokens of a token file's text: ``TOKEN`` or ``NAME TOKEN`` per line (blank lines and
    ``#`` comments skipped). ValueError, with the line, for anything else."""
    tokens: list[Token] = []
    for number, line in enumerate(text.splitlines(), 1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if len(words) > 2:
            raise ValueError(f"line {number}: expected TOKEN or NAME TOKEN, got {len(words)} words")
        name, secret = (words[0], words[1]) if len(words) == 2 else ("", words[0])
        if len(secret) < MIN_TOKEN:
            raise ValueError(f"line {number}: a token must be one word of at least {MIN_TOKEN} characters")
        if len(name) > MAX_NAME:
            raise ValueError(f"line {number}: a name has at most {MAX_NAME} characters")
        if any(t.secret == secret for t in tokens):
            raise ValueError(f"line {number}: this token is given twice")
        tokens.append(Token(secret, name))
    if not tokens:
        raise ValueError(f"no token (one word of at least {MIN_TOKEN} characters, or NAME TOKEN per line)")
    return tuple(tokens)


def read_tokens(path: str) -> tuple[Token, ...]:
    try:
        return parse_tokens(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:  # unreadable, not UTF-8, or not a token file
        raise UsageError(f"--token-file {path}: {exc}") from exc


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def access_for(host: str, token_file: str | None) -> Access:
    """The access rules of a bind on ``host``; UsageError when it is reachable and no token is given."""
    tokens = read_tokens(token_file) if token_file else ()
    if is_loopback(host):
        return Access(tokens, False, tuple(dict.fromkeys((*LOOPBACK_NAMES, host))))
    if not tokens:
        raise UsageError(
            f"--host {host} is reachable from other machines: give --token-file "
            "(every connection then needs the token)"
        )
    return Access(tokens, True, ())


def matching(tokens: Sequence[Token], given: str) -> Token | None:
    """The token equal to ``given`` (compared in constant time, each one), or None."""
    found = None
    for token in tokens:
        if hmac.compare_digest(given.encode(), token.secret.encode()):
            found = token
    return found


def given_token(path: str, headers: Mapping[str, str]) -> str:
    """The token a handshake carries: ``?token=`` in its path, else ``Authorization: Bearer``; "" if none."""
    values = parse_qs(urlsplit(path).query).get("token")
    if values:
        return values[0]
    scheme, _, value = headers.get("Authorization", "").partition(" ")
    return value.strip() if scheme.lower() == "bearer" else ""


def host_name(host_header: str) -> str:
    """The name of a ``Host`` header, without its port (``[::1]:8765`` → ``::1``)."""
    if host_header.startswith("["):
        return host_header[1:].partition("]")[0].lower()
    return (host_header.rpartition(":")[0] if ":" in host_header else host_header).lower()


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (port 0: a free one); UsageError when it cannot be had."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise UsageError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from exc
    sock.listen(128)
    return sock
