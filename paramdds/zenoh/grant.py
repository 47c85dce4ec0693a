"""Whether the router accepted a starting gateway's token: a certificate not granted its own site.

A router's access control (:mod:`.acl`) denies a gateway whose certificate is not
granted its site every message on ``paramdds/<site>/**``: its gateway token, node
tokens, queryables and publications are dropped at the router, silently. The gateway
would log itself active and be heard by nobody.

The denial is observed from a second session of the same gateway (same certificate, same
router), the *probe*: it asks the router, with a liveliness query, for the gateway's own
token. A certificate granted the site may ask for the site's tokens, so the router
answers the probe from what it holds: the token when it accepted it, nothing when its
access control dropped it (a certificate not granted the site gets nothing either: every
named one may ask for the gateways' tokens, :mod:`.acl`, and a query the router refuses
ends at once, without replies). A query the router answered in full ends
before its timeout (its final reply came); one that reached no router ends at its
timeout, or finds the probe without a router. So:

* the token among the replies: **granted** (a healthy gateway, usually at the first ask);
* the router answered in full without it, again and again for :data:`REFUSED_AFTER`
  seconds while both sessions were connected to a router: **refused**. The window is
  longer than the Zenoh lease: a declaration held up on a lossy uplink longer than that
  means the router dropped the gateway's session, which then reconnects and declares
  the token again (the window starts over whenever either session has no router);
* anything else (no answer in time, no router, no probe session) until
  :data:`GIVE_UP_AFTER`: **unknown**, and the gateway goes on serving (it never stops
  unless the router said so).

Asking with the gateway's own session does not work: Zenoh 1.10 answers a session's
liveliness query for its own token from that session, and adds the router's copy only
some of the time (docs/decisions.md, "Across sites").
"""

from __future__ import annotations

import contextlib
import enum
import logging
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from typing import Any

from .config import LEASE_MS, TRY_TIMEOUT, ZenohOptions, open_session
from .states import ENDED_EARLY

log = logging.getLogger(__name__)

ASK = 1.0  # seconds: the timeout of one liveliness query of the probe
PAUSE = 0.2  # seconds between two asks
REFUSED_AFTER = LEASE_MS / 1000 + 1.0  # seconds of full answers without the token before concluding
GIVE_UP_AFTER = 30.0  # seconds after which an unanswered check ends, unknown


class Grant(enum.Enum):
    GRANTED = "granted"
    REFUSED = "refused"
    UNKNOWN = "unknown"


def probe_opener(options: ZenohOptions) -> Callable[[], Any] | None:
    """What opens a gateway's probe session: one more client of the gateway's router, with
    its certificate, each try bounded by :data:`~.config.TRY_TIMEOUT`. None (no check) for
    a gateway that does not dial a router as a client (``--mode peer``, ``--listen``):
    nothing says a router's access control stands between it and its viewers."""
    if options.mode != "client" or not options.connect:
        return None
    return partial(open_session, replace(options, open_timeout=min(options.open_timeout, TRY_TIMEOUT)))


def _has_router(session: Any) -> bool:
    try:
        return any(True for _ in session.info.routers_zid())
    except Exception:  # the session closed under us
        return False


def ask_router(probe: Any, token: str) -> bool | None:
    """One ask: True when the router holds ``token``, False when it answered in full
    without it, None when no full answer came (a timeout, no router)."""
    if not _has_router(probe):
        return None
    started = time.monotonic()
    found = False
    try:
        for reply in probe.liveliness().get(token, timeout=ASK):
            if reply.ok is not None and str(reply.ok.key_expr) == token:
                found = True
    except Exception:  # the session closed under us
        return None
    if found:
        return True
    ended_early = time.monotonic() - started < ASK - ENDED_EARLY
    return False if ended_early and _has_router(probe) else None


def check_token(
    session: Any,
    open_probe: Callable[[], Any],
    token: str,
    *,
    refused_after: float = REFUSED_AFTER,
    give_up_after: float = GIVE_UP_AFTER,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> Grant:
    """Whether the router holds ``token``, declared by ``session``, as seen from a session
    ``open_probe()`` opens (closed here): see the module's rules."""
    started = clock()
    since: float | None = None  # when the router's full answers without the token began
    probe: Any = None
    try:
        while clock() - started < give_up_after:
            if probe is None:
                try:
                    probe = open_probe()
                except Exception as exc:  # UnavailableError: the uplink went meanwhile
                    log.info("grant check: could not open the probe session (%s)", exc)
                    sleep(PAUSE)
                    continue
            answer = ask_router(probe, token) if _has_router(session) else None
            if answer is True:
                return Grant.GRANTED
            if answer is False and _has_router(session):
                since = clock() if since is None else since
                if clock() - since >= refused_after:
                    return Grant.REFUSED
            else:
                since = None
            sleep(PAUSE)
        return Grant.UNKNOWN
    finally:
        if probe is not None:
            with contextlib.suppress(Exception):  # closed already
                probe.close()
