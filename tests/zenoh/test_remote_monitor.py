"""The remote monitor against a hand-written gateway (a plain Zenoh program speaking the JSON contract).

Checks the receiving rules of docs/zenoh.md without DDS: a delta that follows the state
held is applied, one that does not (a lost publication) makes the monitor ask for the
node again, an older ``seq`` is ignored, and a node without its liveliness token is
never shown online.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.zenoh import codec, keys
from paramdds.zenoh.monitor import RemoteParameterMonitor

from .conftest import Fleet

NODE = "ns/robot1"


def _params(**values: float) -> dict[str, tuple[ParameterValue, ParameterDescriptor]]:
    return {
        n: (ParameterValue.of(ParameterType.DOUBLE, v), ParameterDescriptor(n, ParameterType.DOUBLE))
        for n, v in values.items()
    }


class FakeGateway:
    """Answers state queries with ``self.state``; publishes whatever the test says."""

    def __init__(self, session: Any, state: codec.NodeStateMsg | None = None) -> None:
        self.session = session
        self.state = state or codec.NodeStateMsg(
            "s1", NODE, "gw", 1, True, parameters=_params(a=1.0, b=2.0), announced=2
        )
        self.queries = 0
        self.garbage = 0  # the first queries answered with bytes that are not a state
        self.silent = 0  # the first queries not answered at all (a reply lost, a timeout)
        self.lock = threading.Lock()
        self.queryable = session.declare_queryable(
            keys.site_pattern("s1", keys.STATE), self._answer, complete=True
        )
        # the contract's gateway token: how a remote monitor learns that site s1 is up
        self.token = session.liveliness().declare_token(keys.gateway_key("s1", "1_fake"))

    def _answer(self, query: Any) -> None:
        with query:
            with self.lock:
                self.queries += 1
                if self.queries <= self.silent:
                    return
                payload = self.state.encode() if self.queries > self.garbage else b'{"v": 1, \xb4'
            query.reply(keys.node_key("s1", NODE, keys.STATE), payload)

    def publish(self, msg: codec.NodeStateMsg) -> None:
        self.session.put(keys.node_key("s1", NODE, keys.STATE), msg.encode())


def test_deltas_gaps_old_seqs_and_tokens(fleet: Fleet) -> None:
    gw = FakeGateway(fleet.remote())
    monitor = RemoteParameterMonitor(fleet.remote())
    name = "s1/ns/robot1"
    assert monitor.wait_until(lambda s: name in s and s[name].complete, 3.0)
    assert not monitor.snapshot()[name].online  # the gateway says online, but no token: offline

    token = gw.session.liveliness().declare_token(keys.node_key("s1", NODE, keys.ALIVE))
    assert monitor.wait_until(lambda s: s[name].online, 3.0)

    # a delta that follows seq 1: applied (b changed, a deleted, c added)
    delta = codec.NodeStateMsg(
        "s1",
        NODE,
        "gw",
        2,
        True,
        parameters=_params(b=3.0, c=4.0),
        announced=2,
        kind="delta",
        base=1,
        deleted=["a"],
    )
    gw.publish(delta)
    assert monitor.wait_until(lambda s: sorted(s[name].parameters) == ["b", "c"], 3.0)
    assert monitor.snapshot()[name].parameters["b"][0].value == 3.0

    # an old seq is ignored (the delta after it, from the same publisher, arrives after it)
    gw.publish(codec.NodeStateMsg("s1", NODE, "gw", 1, True, parameters=_params(z=9.0), announced=1))
    gw.publish(
        codec.NodeStateMsg(
            "s1", NODE, "gw", 3, True, parameters=_params(c=7.0), announced=2, kind="delta", base=2
        )
    )
    assert monitor.wait_until(lambda s: s[name].parameters["c"][0].value == 7.0, 3.0)
    assert sorted(monitor.snapshot()[name].parameters) == ["b", "c"]
    # a delta after a lost one (base 4, the monitor holds 3): the monitor asks for the node
    with gw.lock:
        before = gw.queries
        gw.state = codec.NodeStateMsg(
            "s1", NODE, "gw", 5, True, parameters=_params(b=5.0, c=6.0), announced=2
        )
    gw.publish(
        codec.NodeStateMsg(
            "s1", NODE, "gw", 5, True, parameters=_params(c=6.0), announced=2, kind="delta", base=4
        )
    )
    assert monitor.wait_until(lambda s: s[name].parameters["b"][0].value == 5.0, 3.0)
    assert gw.queries > before

    token.undeclare()
    assert monitor.wait_until(lambda s: not s[name].online, 3.0)
    monitor.close()


def test_a_state_reply_that_does_not_decode_is_asked_for_again(fleet: Fleet) -> None:
    gw = FakeGateway(fleet.remote())
    gw.garbage = 2  # the first sync's answer and the first ask again: the second one holds
    monitor = RemoteParameterMonitor(fleet.remote())
    name = "s1/ns/robot1"
    assert monitor.wait_until(lambda s: name in s and s[name].complete, 3.0), monitor.snapshot()
    assert gw.queries == 3
    monitor.close()


def test_a_node_whose_token_is_alive_but_whose_state_did_not_come_is_asked_for_again(fleet: Fleet) -> None:
    gw = FakeGateway(fleet.remote())
    gw.silent = 1  # the first sync's query gets no answer (as when its timeout ends first)
    token = gw.session.liveliness().declare_token(keys.node_key("s1", NODE, keys.ALIVE))
    monitor = RemoteParameterMonitor(fleet.remote(), timeout=1.0)
    name = "s1/ns/robot1"
    assert monitor.wait_until(lambda s: name in s and s[name].complete and s[name].online, 4.0)
    assert gw.queries == 2
    monitor.close()
    token.undeclare()


def test_a_nodes_status_reaches_remote_viewers_live_as_an_event_and_in_nodes(fleet: Fleet) -> None:
    """A gateway's state carries the node's status (a ROS 2 mirror shown ``stale`` or
    ``unreachable``): the remote monitor holds it and reports each change as one ``status``
    event while the node stays online, and the remote client's ``nodes()`` shows it."""
    from paramdds.dds.monitor import EventKind, MonitorEvent
    from paramdds.zenoh.client import RemoteParameterClient

    gw = FakeGateway(fleet.remote())
    token = gw.session.liveliness().declare_token(keys.node_key("s1", NODE, keys.ALIVE))
    events: list[MonitorEvent] = []
    monitor = RemoteParameterMonitor(fleet.remote(), on_event=events.append)
    name = "s1/ns/robot1"
    assert monitor.wait_until(lambda s: name in s and s[name].online and s[name].status is None, 3.0)
    stale = codec.NodeStateMsg("s1", NODE, "gw", 2, True, status="stale", announced=2, kind="delta", base=1)
    gw.publish(stale)
    assert monitor.wait_until(lambda s: s[name].status == "stale", 3.0)
    with gw.lock:
        gw.state = codec.NodeStateMsg(
            "s1", NODE, "gw", 2, True, status="stale", parameters=_params(a=1.0, b=2.0), announced=2
        )
    client = RemoteParameterClient(fleet.remote(), timeout=3.0)
    assert [(n.node, n.status) for n in client.nodes()] == [(name, "stale")]
    gw.publish(codec.NodeStateMsg("s1", NODE, "gw", 3, True, announced=2, kind="delta", base=2))
    assert monitor.wait_until(lambda s: s[name].status is None, 3.0)
    shown = [(e.event, e.status) for e in events if e.event in (EventKind.STATUS, EventKind.OFFLINE)]
    assert shown == [(EventKind.STATUS, "stale"), (EventKind.STATUS, None)]
    assert monitor.snapshot()[name].parameters["a"][0].value == 1.0  # the values stay as they were
    client.close()
    monitor.close()
    token.undeclare()


def test_a_gateway_back_within_the_hold_shows_its_site_stale_then_current_again(fleet: Fleet) -> None:
    """The gateway's tokens go (as when the router drops its session) and come back within the
    hold: the node stays online, ``stale`` meanwhile with the values held, then current again
    with the state asked for anew (a change made meanwhile was published to no one); one
    ``site_status`` pair, no offline event."""
    from paramdds.dds.monitor import EventKind, MonitorEvent

    gw = FakeGateway(fleet.remote())
    alive = keys.node_key("s1", NODE, keys.ALIVE)
    token = gw.session.liveliness().declare_token(alive)
    events: list[MonitorEvent] = []
    monitor = RemoteParameterMonitor(fleet.remote(), on_event=events.append)
    name = "s1/ns/robot1"
    assert monitor.wait_until(lambda s: name in s and s[name].online and s[name].complete, 3.0)
    dropped = time.time()
    for entity in (token, gw.token, gw.queryable):
        entity.undeclare()
    assert monitor.wait_until(lambda s: s[name].status == "stale", 3.0)
    assert monitor.snapshot()[name].online and monitor.snapshot()[name].parameters["a"][0].value == 1.0
    changed = codec.NodeStateMsg("s1", NODE, "gw", 2, True, parameters=_params(a=5.0, b=2.0), announced=2)
    back = FakeGateway(gw.session, changed)
    token = back.session.liveliness().declare_token(alive)
    assert monitor.wait_until(lambda s: not s[name].status and s[name].parameters["a"][0].value == 5.0, 3.0)
    assert back.queries >= 1
    site = [(e.event, e.status) for e in events if e.site]
    assert site == [(EventKind.SITE_STATUS, "stale"), (EventKind.SITE_STATUS, None)]
    presence = (EventKind.OFFLINE, EventKind.ONLINE, EventKind.SITE_OFFLINE, EventKind.SITE_ONLINE)
    assert not [e for e in events if e.event in presence and e.stamp >= dropped]
    monitor.close()
    token.undeclare()


def test_a_client_on_the_monitors_session_still_finds_every_site(fleet: Fleet) -> None:
    """The monitor follows the gateways' tokens; a liveliness get on its session (a client's
    ``nodes()``, the monitor's own first sync) must still see them: Zenoh 1.10 answered such a
    get with nothing when the session held a liveliness subscriber with history on those keys."""
    from paramdds.zenoh.client import RemoteParameterClient

    gw = FakeGateway(fleet.remote())
    token = gw.session.liveliness().declare_token(keys.node_key("s1", NODE, keys.ALIVE))
    session = fleet.remote()
    client = RemoteParameterClient(session, timeout=3.0)
    for _ in range(5):
        monitor = RemoteParameterMonitor(session)
        assert [n.node for n in client.nodes()] == ["s1/ns/robot1"]
        assert monitor.wait_until(lambda s: "s1/ns/robot1" in s and s["s1/ns/robot1"].online, 3.0)
        monitor.close()
    client.close()
    token.undeclare()
