"""State queries to many sites (paramdds.zenoh.states.ask_states) on a real Zenoh router:
sites that answer slowly, one that never does, and replies kept byte for byte."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from paramdds.zenoh import codec, keys
from paramdds.zenoh.states import ask_states

from .conftest import free_port, open_remote, open_router


class Sites:
    """A router, and a session per site whose state queryable answers after ``delay`` seconds
    (None: never) with ``nodes`` states."""

    def __init__(self) -> None:
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.router = open_router(self.endpoint)
        self.sessions: list[Any] = []

    def site(self, site: str, nodes: int, delay: float | None) -> None:
        session = open_remote(self.endpoint)
        self.sessions.append(session)

        def answer(query: Any) -> None:
            with query:
                if delay is None:
                    time.sleep(30.0)  # never within the test (the querier's timeout ends it)
                    return
                time.sleep(delay)
                for n in range(nodes):
                    msg = codec.NodeStateMsg(site, f"n{n}", "gw", 1, True, host="h" * 3000)
                    query.reply(keys.node_key(site, f"n{n}", keys.STATE), msg.encode())

        def on_query(query: Any) -> None:
            threading.Thread(target=answer, args=(query,), daemon=True).start()

        session.declare_queryable(keys.site_pattern(site, keys.STATE), on_query, complete=True)

    def close(self) -> None:
        for session in [*self.sessions, self.router]:
            session.close()


@pytest.fixture
def sites() -> Iterator[Sites]:
    s = Sites()
    try:
        yield s
    finally:
        s.close()


def _names(msgs: Any) -> set[str]:
    return {keys.remote_name(m.site, m.node) for m in msgs}


def test_every_site_is_asked_at_once_each_within_its_own_deadline(sites: Sites) -> None:
    # six sites each answering after 0.6 of the timeout: asked a few at a time within one
    # shared deadline, the last ones would have had 0.4 of it left and been lost
    for k in range(6):
        sites.site(f"s{k}", 10, 1.2)
    remote = open_remote(sites.endpoint)
    try:
        time.sleep(0.3)  # the queryables reach the remote session's router
        patterns = [keys.site_pattern(f"s{k}", keys.STATE) for k in range(6)]
        started = time.monotonic()
        got = _names(ask_states(remote, patterns, 2.0))
        took = time.monotonic() - started
    finally:
        remote.close()
    assert got == {f"s{k}/n{n}" for k in range(6) for n in range(10)}
    assert took < 2.0, took


def test_sites_that_never_answer_cost_the_others_nothing(sites: Sites) -> None:
    dead = [f"dead{k}" for k in range(4)]
    for site in dead:
        sites.site(site, 5, None)
    for k in range(4):
        sites.site(f"s{k}", 20, 0.0)
    remote = open_remote(sites.endpoint)
    try:
        time.sleep(0.3)
        patterns = [keys.site_pattern(s, keys.STATE) for s in [*dead, "s0", "s1", "s2", "s3"]]
        seen: list[tuple[float, str]] = []
        started = time.monotonic()
        for msg in ask_states(remote, patterns, 1.5):
            seen.append((time.monotonic() - started, keys.remote_name(msg.site, msg.node)))
    finally:
        remote.close()
    assert {name for _, name in seen} == {f"s{k}/n{n}" for k in range(4) for n in range(20)}
    assert max(t for t, _ in seen) < 1.0  # yielded as each site's query ended, not at the dead ones' end
