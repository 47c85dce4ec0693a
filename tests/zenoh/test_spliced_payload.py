"""A state payload with Zenoh's framing spliced into it: refused, logged by what it holds, asked for again.

Zenoh 1.10 can deliver such a payload when a link is closed while a batch is half
written (docs/zenoh.md "Limits"): the rest of the payload is the next batch, starting with
its 2-byte length (46,128 B: ``30 b4``, the 0xb4 seen) and its frame header. These tests
hand the monitor exactly that shape through a real Zenoh session.
"""

from __future__ import annotations

import threading
from typing import Any

import pytest

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import ErrorCode, OutcomeUnknownError, ParamddsError
from paramdds.zenoh import codec, keys
from paramdds.zenoh.client import RemoteParameterClient
from paramdds.zenoh.monitor import RemoteParameterMonitor
from paramdds.zenoh.states import payload_summary

from .conftest import Fleet

NODE = "robot1"
NAME = f"s1/{NODE}"
KEY = keys.node_key("s1", NODE, keys.STATE)
# what followed the cut in a bench run: a batch length (46,128 LE), a reliable frame with its
# sequence number, a response header, its key
FRAMING = bytes.fromhex("30b425aac9f905fb010025") + keys.node_key("s1", "robot2", keys.STATE).encode()


def _state(seq: int, a: float) -> codec.NodeStateMsg:
    params = {
        "a": (ParameterValue.of(ParameterType.DOUBLE, a), ParameterDescriptor("a", ParameterType.DOUBLE))
    }
    return codec.NodeStateMsg("s1", NODE, "gw", seq, True, parameters=params, announced=1)


def spliced(payload: bytes, cut: int) -> bytes:
    """``payload`` cut at ``cut`` and filled up to its length with the next batch's bytes."""
    rest = FRAMING + b"\xa1\rC\x12\xf0SZ" + payload
    return payload[:cut] + rest[: len(payload) - cut]


class Gateway:
    """Answers state queries with ``self.state``; holds the site's gateway token and the node's."""

    def __init__(self, session: Any) -> None:
        self.session = session
        self.state = _state(1, 1.0)
        self.queries = 0
        self.lock = threading.Lock()
        self.queryable = session.declare_queryable(
            keys.site_pattern("s1", keys.STATE), self._answer, complete=True
        )
        self.token = session.liveliness().declare_token(keys.gateway_key("s1", "1_fake"))
        self.alive = session.liveliness().declare_token(keys.node_key("s1", NODE, keys.ALIVE))

    def _answer(self, query: Any) -> None:
        with query:
            with self.lock:
                self.queries += 1
                payload = self.state.encode()
            query.reply(KEY, payload)


def test_the_summary_shows_the_framing_where_the_payload_was_cut() -> None:
    whole = _state(2, 2.0).encode()
    cut = len(whole) // 2
    text = payload_summary(spliced(whole, cut))
    assert text.startswith(f"{len(whole)} bytes, starting {whole[:12].hex(' ')}")
    assert text.endswith(f"at {cut + 1}: 30 b4 25 aa c9 f9 05 fb 01 00 25 70")
    assert payload_summary(whole) == f"{len(whole)} bytes, starting {whole[:12].hex(' ')}"


def test_a_publication_that_does_not_decode_makes_the_monitor_ask_for_the_node(fleet: Fleet) -> None:
    gw = Gateway(fleet.remote())
    monitor = RemoteParameterMonitor(fleet.remote())
    try:
        assert monitor.wait_until(lambda s: NAME in s and s[NAME].complete and s[NAME].online, 5.0), (
            monitor.snapshot()
        )
        assert monitor.snapshot()[NAME].parameters["a"][0].value == 1.0
        with gw.lock:
            before = gw.queries
            gw.state = _state(2, 2.0)  # the change the spliced publication carried
        whole = gw.state.encode()
        gw.session.put(KEY, spliced(whole, len(whole) - 40))
        # without asking, the monitor would show a = 1.0 as current until the node's next change
        assert monitor.wait_until(lambda s: s[NAME].parameters["a"][0].value == 2.0, 5.0)
        assert gw.queries > before
    finally:
        monitor.close()


def test_a_spliced_reply_is_asked_for_again(fleet: Fleet) -> None:
    gw = Gateway(fleet.remote())
    good = gw.state.encode()
    answers = [spliced(good, 100), good]

    def answer(query: Any) -> None:
        with query:
            with gw.lock:
                gw.queries += 1
                payload = answers.pop(0) if answers else good
            query.reply(KEY, payload)

    gw.queryable.undeclare()
    gw.queryable = gw.session.declare_queryable(keys.site_pattern("s1", keys.STATE), answer, complete=True)
    monitor = RemoteParameterMonitor(fleet.remote())
    try:
        assert monitor.wait_until(lambda s: NAME in s and s[NAME].complete, 5.0), monitor.snapshot()
        assert gw.queries == 2
    finally:
        monitor.close()


def test_a_damaged_reply_to_a_set_is_an_unknown_outcome_and_to_a_get_an_error(fleet: Fleet) -> None:
    """The gateway took the set (it may have been applied) and its reply arrived spliced: the
    caller is told the outcome is unknown, never a failure; a get that its reply was damaged
    (UNAVAILABLE: a fault on the way, never "bad local input")."""
    gw = Gateway(fleet.remote())
    asked: list[str] = []

    def answer(query: Any) -> None:
        with query:
            asked.append(str(query.key_expr))
            good = codec.dumps({"node": NODE, "revision": 2, "results": []})
            query.reply(query.key_expr, spliced(good, len(good) // 2))

    verbs = [gw.session.declare_queryable(keys.site_pattern("s1", v), answer) for v in ("set", "get")]
    client = RemoteParameterClient(fleet.remote(), timeout=5.0)
    try:
        with pytest.raises(OutcomeUnknownError, match="arrived damaged"):
            client.set(NAME, {"a": 3.0})
        with pytest.raises(ParamddsError) as got:
            client.get(NAME, ["a"])
        assert got.value.code is ErrorCode.UNAVAILABLE and "arrived damaged" in str(got.value)
        assert [k.rsplit("/", 1)[1] for k in asked] == ["set", "get"]  # each went out once
    finally:
        client.close()
        for v in verbs:
            v.undeclare()
