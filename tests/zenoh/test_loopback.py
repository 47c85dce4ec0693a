"""Sites on loopback: servers and a gateway per site (real processes), a router and remote clients.

Each site is a DDS domain of its own; the only way between them is the Zenoh router.
"""

from __future__ import annotations

import asyncio
import json
import subprocess
import time
from pathlib import Path

import pytest

from paramdds.core.revision import Revision
from paramdds.dds.client import AsyncParameterClient
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.errors import ErrorCode, UnavailableError
from paramdds.zenoh.client import ROUTE_WAIT, RemoteParameterClient
from paramdds.zenoh.monitor import RemoteParameterMonitor
from paramdds.zenoh.monitor_rules import SITE_HOLD

from ..reliability.conftest import PARAMDDS, make_dds_env
from .conftest import Fleet, free_port, holds_online, wait_for

pytestmark = pytest.mark.timeout(90)


@pytest.mark.slow
def test_a_late_remote_monitor_holds_every_site_exactly_and_calls_reach_every_node(fleet: Fleet) -> None:
    fleet.server("s1", "robot1", "ns/robot2")
    fleet.server("s2", "robot1")
    fleet.gateway("s1")
    fleet.gateway("s2")
    session = fleet.remote()
    client = RemoteParameterClient(session, timeout=5.0)
    # a change made before any remote viewer exists must be in the late joiner's state
    assert client.set("s2/robot1", {"robot.max_velocity": 4.0}).successful

    started = time.monotonic()
    monitor = RemoteParameterMonitor(session)
    names = ["s1/robot1", "s1/ns/robot2", "s2/robot1"]
    assert holds_online(monitor, names, 5.0), monitor.snapshot().keys()
    took = time.monotonic() - started
    snap = monitor.snapshot()
    assert set(snap) == set(names)  # the same node name on two sites stays two nodes
    assert all(st.online and len(st.parameters) == 8 for st in snap.values())
    assert snap["s1/robot1"].parameters["robot.max_velocity"][0].value == 1.5
    assert snap["s2/robot1"].parameters["robot.max_velocity"][0].value == 4.0
    assert snap["s1/robot1"].pid != snap["s2/robot1"].pid
    assert snap["s1/robot1"].parameters["robot.max_velocity"][1].floating_point_range is not None
    assert took < 3.0, took

    # get / describe / list with per-name codes
    reply = client.get("s1/ns/robot2", ["robot.max_velocity", "nope"], with_descriptors=True)
    assert reply.node == "s1/ns/robot2"
    assert reply.values()["robot.max_velocity"].value == 1.5
    assert [r.code for r in reply.missing()] == [ErrorCode.NOT_FOUND]
    assert (
        reply.results[0].descriptor is not None
        and reply.results[0].descriptor.description == "Top speed in m/s"
    )
    assert "robot.max_velocity" in client.list("s1/robot1", ["robot"], 1).names

    # a refusal round trips with its code; the accepted half is applied
    done = client.set("s1/robot1", {"robot.max_velocity": 2.5, "robot.wheel_count": 6})
    assert [(r.name, r.successful, r.code) for r in done.results] == [
        ("robot.max_velocity", True, None),
        ("robot.wheel_count", False, ErrorCode.READ_ONLY),
    ]
    out_of_range = client.set("s1/robot1", {"robot.max_velocity": 9.0})
    assert out_of_range.results[0].code is ErrorCode.OUT_OF_RANGE

    # atomic: all or nothing
    atomic = client.set("s1/robot1", {"robot.max_velocity": 3.0, "robot.wheel_count": 6}, atomic=True)
    assert not atomic.successful
    assert client.get_value("s1/robot1", "robot.max_velocity").value == 2.5

    # compare-and-set on (incarnation, revision)
    at = client.get("s1/robot1", ["robot.max_velocity"]).at
    assert client.set("s1/robot1", {"robot.max_velocity": 3.5}, if_revision=at).successful
    stale = client.set("s1/robot1", {"robot.max_velocity": 3.6}, if_revision=at)
    assert [r.code for r in stale.results] == [ErrorCode.CONFLICT]
    assert stale.at != at and stale.at.incarnation == at.incarnation
    assert not client.set(
        "s1/robot1", {"robot.mode": "off"}, if_revision=Revision(1, at.revision + 1)
    ).successful

    # the monitor follows the changes; the other site's node of the same name is untouched
    assert monitor.wait_until(lambda s: s["s1/robot1"].parameters["robot.max_velocity"][0].value == 3.5, 3.0)
    assert monitor.snapshot()["s2/robot1"].parameters["robot.max_velocity"][0].value == 4.0

    # presence through the client, and a site nobody serves
    assert {n.node for n in client.nodes() if n.online} == set(names)
    started = time.monotonic()
    with pytest.raises(UnavailableError, match="no gateway of site 's9' is reachable"):
        client.get("s9/robot1", ["x"], timeout=2.0)
    # a set that no gateway could receive was never sent: a failure, never "outcome unknown"
    with pytest.raises(UnavailableError, match="the call was not sent"):
        client.set("s9/robot1", {"x": 1}, timeout=5.0)
    assert time.monotonic() - started < 2 * ROUTE_WAIT + 0.5  # not the calls' timeouts

    # the asyncio form (the web console's): the same route rule, served and not
    async def both() -> tuple[float, Exception]:
        remote = AsyncParameterClient(client)
        served = (await remote.get("s1/robot1", ["robot.max_velocity"])).values()["robot.max_velocity"]
        try:
            await remote.set("s8/robot1", {"x": 1}, timeout=5.0)
        except UnavailableError as exc:
            return served.value, exc
        raise AssertionError("a set to a site nobody serves was not refused")

    value, refused = asyncio.run(both())
    assert value == 3.5 and "the call was not sent" in str(refused)  # 3.5: the compare-and-set above
    monitor.close()


@pytest.mark.slow
def test_a_killed_gateway_takes_its_sites_nodes_offline_and_a_standby_takes_over(fleet: Fleet) -> None:
    fleet.server("s1", "robot1", "robot2")
    first = fleet.gateway("s1")
    assert "active" in first.lines[-1][1]
    standby = fleet.gateway("s1")
    assert "standby" in standby.lines[-1][1], standby.lines
    session = fleet.remote()
    events: list[MonitorEvent] = []
    monitor = RemoteParameterMonitor(session, on_event=events.append)
    assert holds_online(monitor, ["s1/robot1", "s1/robot2"], 5.0)
    client = RemoteParameterClient(session, timeout=3.0)
    assert client.set("s1/robot1", {"robot.max_velocity": 2.0}).successful
    assert monitor.wait_until(lambda s: s["s1/robot1"].parameters["robot.max_velocity"][0].value == 2.0, 3.0)

    killed = first.kill()
    standby.wait_for("is active", 5.0)
    assert wait_for(lambda: client.get_value("s1/robot1", "robot.max_velocity").value == 2.0, 3.0)
    took = time.monotonic() - killed
    assert took < 3.0, f"the standby answered {took:.2f} s after the kill"
    # the nodes went offline with the dead gateway's tokens and came back with the standby's
    assert monitor.wait_until(lambda s: all(st.online for st in s.values()), 3.0)
    snap = monitor.snapshot()
    assert set(snap) == {"s1/robot1", "s1/robot2"}  # nothing duplicated, nothing lost
    assert snap["s1/robot1"].parameters["robot.max_velocity"][0].value == 2.0
    assert client.set("s1/robot2", {"robot.mode": "manual"}).successful
    assert monitor.wait_until(lambda s: s["s1/robot2"].parameters["robot.mode"][0].value == "manual", 3.0)

    # with no gateway left the site's nodes show stale, then go offline (the hold), and calls fail fast
    standby.kill()
    assert monitor.wait_until(lambda s: all(st.status == "stale" for st in s.values()), 3.0)
    assert monitor.wait_until(lambda s: not any(st.online for st in s.values()), 1.0 + SITE_HOLD)
    offline = [e for e in events if e.event is EventKind.OFFLINE]
    assert {e.node for e in offline} == {"s1/robot1", "s1/robot2"}
    started = time.monotonic()
    with pytest.raises(UnavailableError):
        client.get("s1/robot1", ["robot.max_velocity"], timeout=3.0)
    with pytest.raises(UnavailableError, match="not sent"):  # known unsent: not outcome-unknown
        client.set("s1/robot1", {"robot.max_velocity": 9.0}, timeout=3.0)
    assert time.monotonic() - started < 1.0
    monitor.close()


@pytest.mark.slow
def test_the_cli_reaches_remote_nodes_with_zenoh(fleet: Fleet) -> None:
    fleet.server("s1", "robot1", "robot2")
    fleet.server("s2", "robot1")
    fleet.gateway("s1")
    fleet.gateway("s2")
    env = make_dds_env(
        fleet.domain("s1") + 1, PARAMDDS_ZENOH=fleet.endpoint
    )  # another domain: DDS reaches nothing

    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([PARAMDDS, *args], env=env, capture_output=True, text=True, timeout=30)

    got = run("get", "s1/robot1", "robot.max_velocity")
    assert (got.returncode, got.stdout) == (0, "robot.max_velocity = double 1.5\n"), got.stderr
    refused = run("set", "s1/robot1", "robot.max_velocity=7.5")
    assert refused.returncode == 1
    assert "must be within [0.0, 5.0]" in refused.stdout
    nodes = run("nodes", "-o", "json")
    assert nodes.returncode == 0, nodes.stderr
    assert '"node": "s1/robot1"' in nodes.stdout
    dumped = run("dump", "s1/robot1")
    assert dumped.returncode == 0 and "max_velocity: 1.5" in dumped.stdout, dumped
    # site globs where a verb takes several nodes
    site = run("nodes", "s1/*", "-o", "json")
    assert [r["node"] for r in json.loads(site.stdout)] == ["s1/robot1", "s1/robot2"], site.stderr
    every = run("nodes", "*/robot1", "-o", "json")
    assert [r["node"] for r in json.loads(every.stdout)] == ["s1/robot1", "s2/robot1"], every.stderr
    both = run("dump", "s*/robot1")
    assert both.returncode == 0, both.stderr
    assert [line for line in both.stdout.splitlines() if not line[:1].isspace()] == [
        "/s1/robot1:",
        "/s2/robot1:",
    ]
    bad = run("nodes", "bad-site/*")
    assert bad.returncode == 2 and "invalid node glob 'bad-site/*': contains '-'" in bad.stderr, bad

    from ..reliability.conftest import Proc

    watch = Proc([PARAMDDS, "watch", "s1/*"], env)
    fleet.procs.append(watch)
    watch.wait_for("added    s1/robot1 robot.max_velocity = double 1.5", 10)
    watch.wait_for("synced", 10)
    assert run("set", "s2/robot1", "robot.max_velocity=3.5").returncode == 0  # not watched
    assert run("set", "s1/robot1", "robot.max_velocity=2.5").returncode == 0
    watch.wait_for("modified s1/robot1 robot.max_velocity = double 2.5", 5)
    shown = {line.split()[1] for _, line in watch.lines if line.startswith(("added", "modified"))}
    assert shown == {"s1/robot1", "s1/robot2"}, shown


@pytest.mark.slow
def test_bad_input_is_a_clear_error_never_a_hang(tmp_path: Path) -> None:
    env = make_dds_env(1)
    nobody = f"tcp/127.0.0.1:{free_port()}"

    def run(*args: str, extra: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [PARAMDDS, *args], env={**env, **(extra or {})}, capture_output=True, text=True, timeout=30
        )

    started = time.monotonic()
    r = run("zenoh", "--site", "s1", "--connect", nobody, "--open-timeout", "1")
    assert r.returncode == 3, r
    assert f"no Zenoh router reachable at {nobody} within 1 s" in r.stderr
    assert time.monotonic() - started < 10
    r = run("get", "s1/robot1", "x", "--timeout", "1", extra={"PARAMDDS_ZENOH": nobody})
    assert r.returncode == 3 and "no Zenoh router reachable" in r.stderr, r
    r = run("zenoh", "--site", "bad-site", "--connect", nobody)
    assert r.returncode == 2 and "invalid site name 'bad-site'" in r.stderr, r
    r = run("zenoh", "--site", "s1", "--connect", "tcp/nowhere")
    assert r.returncode == 2 and "invalid Zenoh endpoint 'tcp/nowhere'" in r.stderr, r
    r = run("zenoh", "--site", "s1", "--zenoh-config", "/nonexistent.json5")
    assert r.returncode == 2 and "does not exist" in r.stderr, r
    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: 'client', connect: { endpoints: [ }")
    r = run("zenoh", "--site", "s1", "--zenoh-config", str(bad))
    assert r.returncode == 2 and f"{bad}: not a valid Zenoh configuration" in r.stderr, r
    good = tmp_path / "good.json5"
    good.write_text(f"{{ mode: 'client', connect: {{ endpoints: ['{nobody}'] }} }}")
    r = run("zenoh", "--site", "s1", "--zenoh-config", str(good), "--open-timeout", "1")
    assert r.returncode == 3 and "no Zenoh router reachable" in r.stderr, r
    assert "Traceback" not in r.stderr


@pytest.mark.slow
def test_the_web_console_in_the_cloud_shows_every_sites_nodes_live(fleet: Fleet) -> None:
    pytest.importorskip("uvicorn", reason="the web extra is not installed")
    import json
    import urllib.request

    from ..reliability.conftest import Proc

    fleet.server("s1", "robot1")
    fleet.server("s2", "robot1")
    fleet.gateway("s1")
    fleet.gateway("s2")
    port = free_port()
    env = make_dds_env(fleet.domain("s1") + 1, PARAMDDS_ZENOH=fleet.endpoint)
    web = Proc([PARAMDDS, "web", "--bind", f"127.0.0.1:{port}"], env)
    fleet.procs.append(web)
    web.wait_for("[WEB] Console on", 20)

    def get(path: str) -> dict[str, object]:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=5) as r:
            obj: dict[str, object] = json.loads(r.read())
            return obj

    assert wait_for(
        lambda: {n["node"] for n in get("/api/nodes")["nodes"]} == {"s1/robot1", "s2/robot1"}, 5.0
    )  # type: ignore[index,union-attr]
    client = RemoteParameterClient(fleet.remote(), timeout=5.0)
    assert client.set("s2/robot1", {"robot.max_velocity": 4.5}).successful

    def shown() -> object:
        rows = get("/api/node?node=s2/robot1")["rows"]
        return next(r["value"] for r in rows if r["name"] == "robot.max_velocity")  # type: ignore[union-attr,index]

    assert wait_for(lambda: shown() == 4.5, 5.0)
