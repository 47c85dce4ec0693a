"""Who a console write is made as: the bearer tokens, the operator a token names, the name a page gives.

A token file holds one token (a word of 16+ characters), or one line per operator,
``NAME TOKEN``: the token then names who writes with it. A write (a set, a delete, an
uploaded file) is recorded by its node as made ``via web``, by :func:`operator`:

1. the name of the token the request carries, when that token names one (what the page
   claims is then ignored);
2. else the name the page sends as ``"as"`` (the operator field, kept by the browser);
3. else the console's own identity, its client's (``paramdds web --as NAME``, else
   ``$PARAMDDS_AS``, else ``USER@host`` of the console's process; with ``--zenoh``, the
   name of its Zenoh certificate before ``USER@host``).

Every one of them is the console's word: the node records it as a claim (``verified``
false). What a node can verify, in secure mode, is the console's own participant.
"""

from __future__ import annotations

import hmac
from collections.abc import Sequence
from dataclasses import dataclass

from .status import WebCode, WebError

MIN_TOKEN = 16  # characters
MAX_NAME = 100  # characters of an operator's name


@dataclass(frozen=True)
class Token:
    """A bearer token the console accepts, and the operator it names ("": none)."""

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


def matching(tokens: Sequence[Token], given: str) -> Token | None:
    """The token equal to ``given`` (compared in constant time, each one), or None."""
    found = None
    for token in tokens:
        if hmac.compare_digest(given.encode(), token.secret.encode()):
            found = token
    return found


def claimed_name(body: dict[str, object]) -> str:
    """The operator's name a write's body gives as ``"as"`` ("" when absent or blank)."""
    raw = body.get("as")
    if raw is None:
        return ""
    if not isinstance(raw, str) or len(raw) > MAX_NAME or not raw.isprintable():
        raise WebError(WebCode.BAD_REQUEST, f"'as' must be a name of at most {MAX_NAME} printable characters")
    return raw.strip()


def operator(token: Token | None, claimed: str, console: str) -> str:
    """Who a write is made as: the token's name, else the page's claim, else the console's identity."""
    if token is not None and token.name:
        return token.name
    return claimed or console
