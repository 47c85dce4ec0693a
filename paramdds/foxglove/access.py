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

from collections.abc import Mapping
from dataclasses import dataclass
from urllib.parse import parse_qs, urlsplit

from ..exits import UsageError
from ..listen import LOOPBACK_NAMES, Token, is_loopback, read_tokens


@dataclass(frozen=True)
class Access:
    """What a bind requires: its tokens, whether connecting needs one, the names it is reached by."""

    tokens: tuple[Token, ...] = ()
    token_to_connect: bool = False
    hosts: tuple[str, ...] = ()  # Host header names accepted (empty: any)

    def may_set(self, token: Token | None) -> bool:
        return token is not None or not self.tokens


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
