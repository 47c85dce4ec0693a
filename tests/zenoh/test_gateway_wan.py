"""A gateway started while its WAN is down waits for the router and then serves its site.

Real processes on loopback: a ``paramdds server`` and a ``paramdds zenoh`` gateway on a DDS
domain of their own, and a Zenoh router session in the test process started only after the
gateway, on the port the gateway dials.
"""

from __future__ import annotations

import time

import pytest

from paramdds.zenoh.client import RemoteParameterClient

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .conftest import Fleet, free_port, open_remote, open_router, wait_for

pytestmark = pytest.mark.timeout(90)


@pytest.mark.slow
def test_a_gateway_started_before_its_router_waits_and_then_serves_its_nodes(fleet: Fleet) -> None:
    fleet.server("s1", "robot1")
    endpoint = f"tcp/127.0.0.1:{free_port()}"  # nobody listens here yet
    gateway = Proc(
        [PARAMDDS, "zenoh", "--site", "s1", "--connect", endpoint], make_dds_env(fleet.domain("s1"))
    )
    fleet.procs.append(gateway)

    def tries() -> int:
        return gateway.stderr_text().count(f"no Zenoh router reachable at {endpoint} (try ")

    # the WAN is down at boot: the gateway tries again and again, logging each try, and stays up
    assert wait_for(lambda: tries() >= 3, 20.0), gateway.stderr_text()
    assert gateway.popen.poll() is None, gateway.stderr_text()
    assert not gateway.lines, gateway.lines  # nothing served, nothing said served

    router = open_router(endpoint)
    try:
        gateway.wait_for("[ZENOH] Gateway for site s1", 20)  # it connects on its own
        assert "reached the Zenoh router" in gateway.stderr_text()
        remote = open_remote(endpoint)
        try:
            client = RemoteParameterClient(remote, timeout=5.0)
            client.wait_for_node("s1/robot1", 10.0)
            assert client.get_value("s1/robot1", "robot.max_velocity").value == 1.5
            assert client.set("s1/robot1", {"robot.max_velocity": 2.5}).successful
        finally:
            remote.close()
    finally:
        router.close()

    # once connected, a cut of the router is ridden out: the gateway reconnects on its own
    time.sleep(2.0)
    router = open_router(endpoint)
    try:
        remote = open_remote(endpoint)
        try:
            client = RemoteParameterClient(remote, timeout=5.0)
            client.wait_for_node("s1/robot1", 20.0)
            assert client.get_value("s1/robot1", "robot.max_velocity").value == 2.5
        finally:
            remote.close()
    finally:
        router.close()
    assert gateway.popen.poll() is None, gateway.stderr_text()


@pytest.mark.slow
def test_the_web_console_over_zenoh_names_the_router_not_a_dds_domain(fleet: Fleet) -> None:
    pytest.importorskip("uvicorn", reason="the web extra is not installed")
    import json
    import urllib.request

    port = free_port()
    env = make_dds_env(fleet.domain("s1"), PARAMDDS_ZENOH=fleet.endpoint)
    web = Proc([PARAMDDS, "web", "--bind", f"127.0.0.1:{port}"], env)
    fleet.procs.append(web)
    _, line = web.wait_for("[WEB] Console on", 20)
    assert line.endswith(f"(zenoh {fleet.endpoint}, writes allowed)"), line
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/info", timeout=5) as r:
        info = json.loads(r.read())
    assert info["zenoh"] == fleet.endpoint  # the page's badge shows it in place of "domain N"
