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

from ..listen import MAX_NAME, Token
from .status import WebCode, WebError


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
