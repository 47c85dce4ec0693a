"""What a front end that listens needs (the web console, the Foxglove server): its socket, its
tokens, and the monitor's events handed over to its event loop (:class:`Handover`).

A token file holds one token (a word of 16+ characters) or one line per operator, ``NAME
TOKEN`` (blank lines and ``#`` comments skipped): a write made with a named token is
recorded as made by NAME. Tokens are compared in constant time. A bind on a loopback
address serves this machine only; the front ends' rules for other binds are theirs
(docs/web.md, docs/foxglove.md).
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import ipaddress
import socket
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Generic, TypeVar

from .exits import UsageError

MIN_TOKEN = 16  # characters
MAX_NAME = 100  # characters of an operator's name
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")


@dataclass(frozen=True)
class Token:
    """A bearer token a front end accepts, and the operator it names ("": none)."""

    secret: str
    name: str = ""


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
    """The tokens of ``--token-file``; a file that is not a token file is a usage error naming it."""
    try:
        return parse_tokens(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:  # unreadable, not UTF-8, or not a token file
        raise UsageError(f"--token-file {path}: {exc}") from exc


def matching(tokens: Sequence[Token], given: str) -> Token | None:
    """The token equal to ``given`` (compared in constant time, each one), or None."""
    found = None
    for token in tokens:
        if hmac.compare_digest(given.encode(), token.secret.encode()):
            found = token
    return found


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address) is this machine's loopback."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


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
    sock.set_inheritable(True)
    return sock


T = TypeVar("T")


class Handover(Generic[T]):
    """Items put from any thread (a monitor's events, on Cyclone's thread) reach ``flush`` on
    the asyncio ``loop`` as one list per burst, in order: a flush is scheduled only when none
    is pending (``delay`` s after the burst's first item), so a burst costs the loop one call.
    Once closed, nothing more is scheduled."""

    def __init__(
        self, loop: asyncio.AbstractEventLoop, flush: Callable[[list[T]], None], delay: float = 0.0
    ) -> None:
        self._loop = loop
        self._flush = flush
        self._delay = delay
        self._lock = threading.Lock()
        self._pending: list[T] = []
        self._scheduled = False
        self._closed = False

    def put(self, item: T) -> None:
        with self._lock:
            self._pending.append(item)
            if self._scheduled or self._closed:
                return
            self._scheduled = True
        with contextlib.suppress(RuntimeError):  # the loop is closed: the front end is stopping
            if self._delay > 0:
                self._loop.call_soon_threadsafe(self._loop.call_later, self._delay, self._run)
            else:
                self._loop.call_soon_threadsafe(self._run)

    def close(self) -> None:
        with self._lock:
            self._closed = True

    def drain(self) -> None:
        """Hand what is pending to ``flush`` now (on the loop's thread; a scheduled run finds
        nothing left)."""
        self._run()

    def _run(self) -> None:
        with self._lock:
            items, self._pending = self._pending, []
            self._scheduled = False
        if items:
            self._flush(items)
