"""The past across sites: history of a remote site's node, who over Zenoh, paging on the wire.

Real processes: a ``paramdds server`` and a ``paramdds zenoh`` gateway per site, a router
session here; the only way to the site is the router.
"""

from __future__ import annotations

import asyncio
import json
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.history import Outcome, rewind
from paramdds.core.monitor_events import EventKind, MonitorEvent
from paramdds.core.values import ParameterValue
from paramdds.dds.client import AsyncParameterClient
from paramdds.errors import ErrorCode, NoHistoryError
from paramdds.zenoh import codec, history, keys
from paramdds.zenoh.client import ROUTE_WAIT, RemoteParameterClient, remote_identity
from paramdds.zenoh.monitor import RemoteParameterMonitor
from paramdds.zenoh.states import GRANT_ASK

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .conftest import Fleet, holds_online, wait_for

pytestmark = pytest.mark.timeout(90)

NODE = "s1/robot1"
fv = ParameterValue.from_python


def _ask(session: Any, key: str, body: dict[str, object]) -> dict[str, Any]:
    """One raw query, as any Zenoh program sends it; its one reply's JSON."""
    replies = list(session.get(key, payload=codec.dumps({**body, "timeout": 3.0}), timeout=4.0))
    assert len(replies) == 1 and replies[0].ok is not None, replies
    return codec.loads(replies[0].ok.payload.to_bytes(), "a reply")


@pytest.mark.slow
def test_history_of_a_remote_sites_node_lists_changes_made_from_the_cloud_via_zenoh(fleet: Fleet) -> None:
    fleet.server("s1", "robot1")
    fleet.gateway("s1")
    session = fleet.remote()
    alice = RemoteParameterClient(session, timeout=5.0, as_="alice")
    bob = RemoteParameterClient(session, timeout=5.0, as_="bob")
    assert alice.set(NODE, {"robot.max_velocity": 2.5}).successful
    assert bob.set(NODE, {"robot.max_velocity": 3.0, "robot.name": "r2"}).successful
    refused = bob.set(NODE, {"robot.max_velocity": 9.0})
    assert refused.results[0].code is ErrorCode.OUT_OF_RANGE

    reply = alice.history(NODE)
    assert reply.node == NODE and not reply.compacted
    started = [r for r in reply.records if r.via == "start"]
    n = len(started)
    assert n == 8 and all(r.old is None and r.applied for r in started)  # examples/params.yaml
    assert reply.records[:n] == tuple(started)
    rows = [(r.node, r.name, r.who, r.verified, r.via, r.old, r.new, r.applied) for r in reply.records[n:]]
    assert rows == [
        (NODE, "robot.max_velocity", "alice", False, "zenoh", fv(1.5), fv(2.5), True),
        (NODE, "robot.max_velocity", "bob", False, "zenoh", fv(2.5), fv(3.0), True),
        (NODE, "robot.name", "bob", False, "zenoh", fv("my_robot"), fv("r2"), True),
        (NODE, "robot.max_velocity", "bob", False, "zenoh", fv(3.0), fv(9.0), False),
    ]
    assert reply.records[-1].code == ErrorCode.OUT_OF_RANGE.value and "5.0" in reply.records[-1].reason
    seqs = [r.seq for r in reply.records]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)

    assert asyncio.run(AsyncParameterClient(alice).history(NODE)) == reply  # the web console's form

    # the filters cross the gateway: by name, author, outcome, revision
    by_bob = alice.history(NODE, ["robot.max_velocity"], who="b*", outcome=Outcome.APPLIED)
    assert [(r.who, r.new) for r in by_bob.records] == [("bob", fv(3.0))]
    after = alice.history(NODE, since_revision=reply.records[n].revision)
    assert [r.who for r in after.records] == ["bob", "bob", "bob"]
    assert [r.who for r in alice.history(NODE, outcome=Outcome.REFUSED).records] == ["bob"]

    # the node as it was before alice's change, rebuilt from its history across the site (what
    # diff NODE@REV does with the client)
    before = reply.records[n - 1].revision
    now = alice.get(NODE, ["robot.max_velocity", "robot.name"]).values()
    then = rewind(now, alice.history(NODE, since_revision=before).records)
    assert (then["robot.max_velocity"], then["robot.name"]) == (fv(1.5), fv("my_robot"))

    # a get with descriptors carries each parameter's last change across the gateway
    (got,) = alice.get(NODE, ["robot.name"], with_descriptors=True).results
    assert got.last_change is not None and (got.last_change.who, got.last_change.via) == ("bob", "zenoh")

    # one page per query on the wire: a Zenoh program pages with after_seq
    key = keys.node_key("s1", "robot1", "history")
    first = _ask(session, key, {"limit": 4})
    assert first["ok"] and first["kept"] and first["more"] and not first["compacted"]
    assert [r["seq"] for r in first["records"]] == seqs[:4]
    assert first["records"][0]["node"] == NODE
    rest = _ask(session, key, {"after_seq": first["records"][-1]["seq"]})
    assert not rest["more"] and [r["seq"] for r in rest["records"]] == seqs[4:]
    page, kept = history.page_of(rest)
    assert kept and page.records == reply.records[4:]

    # a malformed request is a clear error, never silence
    bad = _ask(session, key, {"outcome": "maybe"})
    assert not bad["ok"] and "'outcome' must be one of all, applied, refused" in bad["message"]

    # the CLI over Zenoh: --as names the writer, describe shows the last author
    cli = [PARAMDDS, "--zenoh", fleet.endpoint, "--timeout", "5"]
    env = make_dds_env(fleet.domain("cloud"))
    done = subprocess.run([*cli, "--as", "carol", "set", NODE, "robot.max_acceleration=0.5"], env=env,
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 0, done.stderr
    done = subprocess.run([*cli, "describe", NODE, "robot.max_acceleration", "-o", "json"], env=env,
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 0, done.stderr
    blame = json.loads(done.stdout)["robot.max_acceleration"]["last_change"]
    assert (blame["who"], blame["verified"], blame["via"]) == ("carol", False, "zenoh")
    assert blame["time"].endswith("Z") and blame["revision"] > reply.records[-1].revision

    # history and diff over --zenoh: the same records; the node against itself before carol
    done = subprocess.run([*cli, "history", NODE, "robot.max_acceleration", "-o", "json"], env=env,
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = json.loads(done.stdout)
    last = rows[-1]
    assert (last["node"], last["who"], last["via"], last["outcome"]) == (NODE, "carol", "zenoh", "applied")
    assert (last["old"], last["new"]) == (0.8, 0.5)
    at = blame["revision"] - 1
    done = subprocess.run([*cli, "diff", f"{NODE}@{at}", NODE], env=env, capture_output=True, text=True)
    assert done.returncode == 1, done.stderr
    assert done.stdout.splitlines() == ["robot.max_acceleration: 0.8 → 0.5"], done.stdout


def test_a_remote_client_claims_its_as_name_else_its_certificates_else_user_at_host(tmp_path: Path) -> None:
    pytest.importorskip("cryptography", reason="the secure extra (cryptography) is not installed")
    from paramdds.secure.keystore import init_keystore
    from paramdds.zenoh.tls import issue

    certs = issue(init_keystore(tmp_path / "ks"), "operator", [], tmp_path / "operator")
    tls = {"PARAMDDS_ZENOH_TLS": str(certs)}
    assert remote_identity(tls) == "operator"
    assert remote_identity({**tls, "PARAMDDS_AS": "ops"}) == "ops"
    assert remote_identity({}) == remote_identity({"PARAMDDS_ZENOH_TLS": str(tmp_path)})  # no cert.pem there
    assert "@" in remote_identity({})


@pytest.mark.slow
def test_blame_of_a_change_made_from_the_cloud_reaches_a_remote_monitor_live_and_late(fleet: Fleet) -> None:
    fleet.server("s1", "robot1")
    fleet.gateway("s1")
    session = fleet.remote()
    events: list[MonitorEvent] = []
    live = RemoteParameterMonitor(session, on_event=events.append)
    assert holds_online(live, [NODE], 5.0)
    start = live.last_change(NODE, "robot.max_velocity")
    assert start is not None and start.via == "start" and start.verified  # the server's own, at its start

    client = RemoteParameterClient(session, timeout=5.0, as_="alice")
    done = client.set(NODE, {"robot.max_velocity": 2.5})
    assert wait_for(lambda: any(e.event is EventKind.MODIFIED for e in events), 3.0)
    (event,) = [e for e in events if e.event is EventKind.MODIFIED]
    lc = event.last_change
    assert lc is not None and event.name == "robot.max_velocity"
    assert (lc.who, lc.verified, lc.via, lc.revision) == ("alice", False, "zenoh", done.revision)
    assert live.last_change(NODE, "robot.max_velocity") == lc

    # the same value set again by bob: no value changed, and the new author still crosses
    bob = RemoteParameterClient(session, timeout=5.0, as_="bob")
    again = bob.set(NODE, {"robot.max_velocity": 2.5})

    def by_bob() -> bool:
        now = live.last_change(NODE, "robot.max_velocity")
        return now is not None and (now.who, now.revision) == ("bob", again.revision)

    assert wait_for(by_bob, 3.0), live.last_change(NODE, "robot.max_velocity")
    assert live.snapshot()[NODE].revision == again.revision
    bob.set(NODE, {"robot.max_velocity": 2.5}, as_="alice")  # a call's own claim
    assert wait_for(lambda: getattr(live.last_change(NODE, "robot.max_velocity"), "who", "") == "alice", 3.0)
    lc = live.last_change(NODE, "robot.max_velocity")
    assert lc is not None

    # a late joiner reads it from the gateway's state, with no extra call; the same record's time
    late = RemoteParameterMonitor(session)
    assert holds_online(late, [NODE], 5.0)
    assert late.last_change(NODE, "robot.max_velocity") == lc
    other = late.last_change(NODE, "robot.name")
    assert other is not None and (other.who, other.via) == (start.who, "start")
    records = client.history(NODE, ["robot.max_velocity"]).records
    assert [(r.who, r.via) for r in records[1:]] == [("alice", "zenoh"), ("bob", "zenoh"), ("alice", "zenoh")]
    record = records[-1]
    assert (record.who, record.revision) == ("alice", lc.revision)
    assert abs(record.time_ns - lc.time_ns) < 2_000  # the same commit's time (a state's stamp is a float)
    live.close()
    late.close()


def test_a_site_whose_gateway_serves_no_history_says_so_at_once(fleet: Fleet) -> None:
    """An older gateway (here a bare session: its tokens and a get queryable) serves calls but
    not history: NO_HISTORY, never "not granted" or a hang."""
    old = fleet.remote()
    live = old.liveliness()
    tokens = [
        live.declare_token(k) for k in (keys.gateway_key("old", "1_x"), keys.active_key("old", "1_x", 1))
    ]
    get = old.declare_queryable(keys.site_pattern("old", "get"), lambda q: q.drop(), complete=True)
    client = RemoteParameterClient(fleet.remote(), timeout=5.0)
    started = time.monotonic()
    with pytest.raises(NoHistoryError, match="the gateway of site 'old' serves no history"):
        client.history("old/robot1")
    assert time.monotonic() - started < ROUTE_WAIT + 2 * GRANT_ASK + 0.5
    client.close()
    get.undeclare()
    for token in tokens:
        token.undeclare()


@pytest.mark.slow
def test_watch_since_a_revision_over_zenoh_replays_then_goes_live_with_who(fleet: Fleet) -> None:
    fleet.server("s1", "robot1")
    fleet.gateway("s1")
    client = RemoteParameterClient(fleet.remote(), timeout=5.0, as_="alice")
    assert client.set(NODE, {"robot.max_velocity": 2.0}).successful
    watch = Proc(
        [PARAMDDS, "--zenoh", fleet.endpoint, "watch", NODE, "--since", "1"], make_dds_env(fleet.domain("x"))
    )
    fleet.procs.append(watch)
    _, replayed = watch.wait_for(lambda line: "robot.max_velocity" in line, 15.0)
    assert "2.0" in replayed and "(rev 2)" in replayed and "by alice (claimed) via zenoh" in replayed
    watch.wait_for("synced", 10.0)
    assert client.set(NODE, {"robot.max_velocity": 2.5}, as_="bob").successful
    _, live = watch.wait_for(lambda line: "robot.max_velocity" in line, 10.0)
    assert "2.5" in live and "(rev 3)" in live and "by bob (claimed) via zenoh" in live


def test_a_remote_node_that_keeps_no_history_says_so_through_its_gateway(
    fleet: Fleet, domain_id: int
) -> None:
    from paramdds.core.table import ParameterTable
    from paramdds.zenoh.gateway import Gateway

    from ..dds.helpers import DdsSession

    with DdsSession(domain_id) as dds:
        table = ParameterTable("old_peer")
        table.declare("speed", 1.0)
        server = dds.server(table)
        server._histories.pop("old_peer")  # what a peer without history answers: history_kept FALSE
        gateway = Gateway(dds.participant("gateway"), fleet.remote(), "s1")
        try:
            client = RemoteParameterClient(fleet.remote(), timeout=5.0)
            client.wait_for_node("s1/old_peer")
            with pytest.raises(NoHistoryError, match="node 's1/old_peer' keeps no history"):
                client.history("s1/old_peer")
        finally:
            gateway.close()


@pytest.mark.slow
def test_a_range_past_a_remote_nodes_retention_is_said_compacted(fleet: Fleet) -> None:
    fleet.server("s1", "robot1", extra=("--history-records", "3"))
    fleet.gateway("s1")
    client = RemoteParameterClient(fleet.remote(), timeout=5.0, as_="alice")
    for v in (2.0, 2.5, 3.0):
        assert client.set(NODE, {"robot.max_velocity": v}).successful
    everything = client.history(NODE)
    assert everything.compacted and [r.new for r in everything.records] == [fv(2.0), fv(2.5), fv(3.0)]
    recent = client.history(NODE, since_revision=everything.records[0].revision)
    assert not recent.compacted and [r.new for r in recent.records] == [fv(2.5), fv(3.0)]
