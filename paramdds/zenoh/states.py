"""The gateways' node states, asked for: what the remote monitor and client both query.

:func:`ask_states` gets every node state the gateways hold for some key patterns (every
query at once, each with its own deadline); :func:`gateways_of` and :func:`sites_of` the
gateways and sites up; :func:`payload_summary` what a payload that did not decode holds.
"""

from __future__ import annotations

import logging
import queue
import time
from collections.abc import Iterator, Sequence
from typing import Any

import zenoh

from ..errors import ParamddsError
from . import codec, keys

log = logging.getLogger(__name__)

ROUTE_WAIT = 1.0  # seconds a first query to a site waits to learn a gateway serves it
GRANT_ASK = 0.5  # seconds a query with no route asks the router whether the site's gateway is up
REPLY_MARGIN = 0.5  # seconds past a query's timeout before its asker stops waiting for Zenoh
ENDED_EARLY = 0.05  # seconds: a query that ended this much before its timeout was answered in full
_Ended = tuple[str, bool, list[tuple[str, bytes]]]  # a query's pattern, whether it ended in time, its replies


def ask_states(
    session: Any,
    patterns: Sequence[str],
    timeout: float,
    bad: list[str] | None = None,
    answered: set[str] | None = None,
) -> Iterator[codec.NodeStateMsg]:
    """Every node state the gateways answer for ``patterns``, yielded as each query ends; the
    keys of replies that do not decode are added to ``bad``, and the patterns whose query
    ended before its timeout (every gateway that serves it sent all its replies) to
    ``answered``.

    Every query is sent at once, each bounded by its own ``timeout``: a site slowed by loss
    takes none of the others' time (asked one after the other, or a few at a time within
    one shared deadline, a site at 30 % loss was once still missing after 10 s). Each
    query is answered by its own site's gateway, so the replies come as one stream per
    uplink, not as one burst through a single query (one query for every site, 30 sites x
    100 nodes, gave 605 of 3,000 states in 10 s and lost the session on a Python router).
    Zenoh's thread only keeps each reply's bytes; they are decoded here, so a large answer
    never holds up the session."""
    ended: queue.SimpleQueue[_Ended] = queue.SimpleQueue()
    asked = list(dict.fromkeys(patterns))
    for pattern in asked:
        _send_query(session, pattern, timeout, ended)
    last = time.monotonic() + timeout + REPLY_MARGIN  # the last query's own deadline, and a margin
    for _ in asked:
        try:
            pattern, complete, replies = ended.get(timeout=max(0.0, last - time.monotonic()))
        except queue.Empty:
            log.warning("state queries did not end within %g s", timeout)
            return
        if complete and answered is not None:
            answered.add(pattern)
        for key, payload in replies:
            try:
                yield codec.NodeStateMsg.decode(payload)
            except ParamddsError as exc:
                log.warning("ignoring a state from %s (%s): %s", key, payload_summary(payload), exc)
                if bad is not None:
                    bad.append(key)


def payload_summary(payload: bytes) -> str:
    """A payload that did not decode, for a log line: its length, its first bytes, and the
    bytes from just before its first byte over 0x7f (the JSON is ASCII but for non-ASCII
    text; Zenoh's framing spliced into a payload shows there as a 2-byte batch length and a
    frame header, docs/zenoh.md "Limits")."""
    text = f"{len(payload)} bytes, starting {payload[:12].hex(' ')}"
    at = next((i for i, byte in enumerate(payload) if byte > 0x7F), None)
    if at is not None:
        text += f", at {at}: {payload[max(0, at - 1) : at + 11].hex(' ')}"
    return text


def _send_query(session: Any, pattern: str, timeout: float, ended: queue.SimpleQueue[_Ended]) -> None:
    """Ask every gateway for the states of ``pattern``: the pattern, whether the query ended
    before ``timeout`` (every queryable sent its final reply) and (key, payload) of each reply
    go to ``ended`` once the query ends."""
    replies: list[tuple[str, bytes]] = []
    until = time.monotonic() + timeout - ENDED_EARLY

    def on_reply(reply: Any) -> None:
        sample = reply.ok
        if sample is not None:
            replies.append((str(sample.key_expr), sample.payload.to_bytes()))

    session.get(
        pattern,
        zenoh.handlers.Callback(on_reply, lambda: ended.put((pattern, time.monotonic() < until, replies))),
        timeout=timeout,
        target=zenoh.QueryTarget.ALL,
        consolidation=zenoh.QueryConsolidation(zenoh.ConsolidationMode.NONE),
    )


def gateways_of(session: Any, timeout: float, site: str = "*") -> dict[str, set[str]]:
    """The gateways up now of ``site`` (``*``: every site), by site (their liveliness tokens)."""
    found: dict[str, set[str]] = {}
    for reply in session.liveliness().get(keys.gateways_pattern(site), timeout=timeout):
        if reply.ok is not None:
            key = str(reply.ok.key_expr)
            try:
                gateway, active_since = keys.parse_gateway_key(key)
                name = keys.check_site(key.split("/")[1])
            except (ParamddsError, IndexError):
                continue
            if active_since is None:
                found.setdefault(name, set()).add(gateway)
    return found


def sites_of(session: Any, timeout: float, site: str = "*") -> list[str]:
    """The sites (of ``site``, a site or ``*``) whose gateway is up now (a gateway's liveliness
    token names its site)."""
    return sorted(gateways_of(session, timeout, site))


def site_active(session: Any, site: str) -> bool:
    """Whether the router shows an active gateway of ``site`` (every certificate may see the
    gateways' tokens, :mod:`.acl`): then a query that no gateway of it serves was refused
    this client by the router's access control."""
    try:
        replies = session.liveliness().get(f"{keys.gateway_key(site, '*')}/active/*", timeout=GRANT_ASK)
        return any(r.ok is not None for r in replies)
    except Exception:  # the session closed under us
        return False
