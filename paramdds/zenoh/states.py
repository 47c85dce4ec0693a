"""The gateways' node states, asked for: what the remote monitor and client both query.

:func:`ask_states` gets every node state the gateways hold for some key patterns (a few
queries in flight at once, each bounded); :func:`sites_of` the sites whose gateway is up.
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
PARALLEL_QUERIES = 4  # state queries in flight at once (see ask_states)
REPLY_MARGIN = 0.5  # seconds past a query's timeout before its asker stops waiting for Zenoh
_ALL_GATEWAYS = f"{keys.PREFIX}/*/gateway/*"  # the gateways' tokens (not the active ones': one chunk more)
ENDED_EARLY = 0.05  # seconds: a query that ended this much before its timeout was answered in full
_Ended = tuple[str, bool, list[tuple[str, bytes]]]  # a query's pattern, whether it ended in time, its replies


def ask_states(
    session: Any,
    patterns: Sequence[str],
    timeout: float,
    bad: list[str] | None = None,
    answered: set[str] | None = None,
) -> Iterator[codec.NodeStateMsg]:
    """Every node state the gateways answer for ``patterns``, all within ``timeout``, yielded
    as each query ends; the keys of replies that do not decode are added to ``bad``, and the
    patterns whose query ended before its timeout (every gateway that serves it sent all its
    replies) to ``answered``.

    Up to :data:`PARALLEL_QUERIES` queries are in flight at once, each bounded by what is
    left of ``timeout``. One query for every site at once was measured to fail: 30 sites x
    100 nodes (20 MB of replies) gave 605 of 3,000 states in 10 s and lost the session, on a
    Python router. One site after the other left a site slowed by loss all the time of the
    sites before it: at 30 % loss a site's nodes were once still missing after 10 s.
    Replies are only gathered in Zenoh's thread and decoded here, so a large answer never
    holds up the session."""
    deadline = time.monotonic() + timeout
    waiting = list(patterns)
    ended: queue.SimpleQueue[_Ended] = queue.SimpleQueue()
    in_flight = 0
    while waiting or in_flight:
        while waiting and in_flight < PARALLEL_QUERIES:
            pattern = waiting.pop(0)
            left = deadline - time.monotonic()
            if left <= 0:
                log.warning("no time left to ask for the states of %s", pattern)
                continue
            _send_query(session, pattern, left, ended)
            in_flight += 1
        if not in_flight:
            return
        try:
            left = max(0.0, deadline - time.monotonic())
            pattern, complete, replies = ended.get(timeout=left + REPLY_MARGIN)
        except queue.Empty:
            log.warning("%d state queries did not end within %g s", in_flight, timeout)
            return
        in_flight -= 1
        if complete and answered is not None:
            answered.add(pattern)
        for key, payload in replies:
            try:
                yield codec.NodeStateMsg.decode(payload)
            except ParamddsError as exc:
                log.warning("ignoring a state from %s: %s", key, exc)
                if bad is not None:
                    bad.append(key)


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


def sites_of(session: Any, timeout: float, site: str = "*") -> list[str]:
    """The sites (of ``site``, a site or ``*``) whose gateway is up now (a gateway's liveliness
    token names its site)."""
    sites: set[str] = set()
    pattern = _ALL_GATEWAYS if site == "*" else f"{keys.PREFIX}/{site}/gateway/*"
    for reply in session.liveliness().get(pattern, timeout=timeout):
        if reply.ok is not None:
            try:
                sites.add(keys.check_site(str(reply.ok.key_expr).split("/")[1]))
            except (ParamddsError, IndexError):
                continue
    return sorted(sites)


def site_active(session: Any, site: str) -> bool:
    """Whether the router shows an active gateway of ``site`` (every certificate may see the
    gateways' tokens, :mod:`.acl`): then a query that no gateway of it serves was refused
    this client by the router's access control."""
    try:
        replies = session.liveliness().get(f"{keys.gateway_key(site, '*')}/active/*", timeout=GRANT_ASK)
        return any(r.ok is not None for r in replies)
    except Exception:  # the session closed under us
        return False
