"""Where the session's features meet: the web console, incarnations, secure mode and the
discovery fix on the ROS 2 bridge's mirrored and exposed nodes. Real rclpy nodes in
subprocesses, a real bridge, real consoles; each test failed before its fix."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from paramdds.dds.participant import close_participant, make_participant

from ..web import conftest as web
from ..web._support import Console
from ..web.test_browser import open_node, row

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]

# the web tests' headless Chromium (a tab: "web_page")
browser, web_page = web.browser, web.page


@pytest.fixture
def console(domain_id: int, bridge: Any) -> Iterator[Console]:
    c = Console(domain_id)
    yield c
    c.stop()


def get(console: Console, path: str, **params: str) -> Any:
    r = httpx.get(console.url + path, params=params, timeout=10)
    assert r.status_code == 200, r.text
    return r.json()


def post(console: Console, route: str, body: dict[str, Any]) -> httpx.Response:
    return httpx.post(console.url + "api/" + route, json=body, timeout=15)


def wait_summary(console: Console, name: str, predicate: Any, timeout: float = 30.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        r = httpx.get(console.url + "api/node", params={"node": name}, timeout=10)
        if r.status_code == 200 and predicate(r.json()["summary"]):
            return r.json()["summary"]  # type: ignore[no-any-return]
        assert time.monotonic() < deadline, f"{name}: {r.text}"
        time.sleep(0.1)


def test_the_console_applies_atomically_on_a_mirrored_node_and_shows_its_refusal(
    ros_hosts: Any, console: Console, web_page: Any
) -> None:
    """ "Apply atomically" sent the page's (incarnation, revision) with every atomic set, and
    the bridge refuses compare-and-set on a mirror: on a ROS 2 node the button never worked
    ("compare-and-set is not available..."), the edits stayed dirty. Now the page sends the
    atomic set without one, says so, and a refusal shows the node's own reason."""
    from playwright.sync_api import expect

    page = web_page

    host = ros_hosts("--rich", "/robot/rich")
    wait_summary(console, "robot/rich", lambda s: s["online"] and s["origin"] == "ros2")
    open_node(page, console, "/robot/rich")  # a ROS 2 node: shown with its slash
    expect(page.locator('#nodes li[data-node="robot/rich"] .origin')).to_have_text("ros2")
    row(page, "mode").locator('[data-role="input"]').fill("manual")
    row(page, "limits.count").locator('[data-role="input"]').fill("6")
    page.click("#apply")
    expect(page.locator("#banner")).to_contain_text("Applied 2 changes atomically")
    expect(page.locator("#banner")).to_contain_text("mirrored from ros2, which has no revisions")
    assert host.command("get /robot/rich mode") == 'value "manual"'
    assert host.command("get /robot/rich limits.count") == "value 6"
    expect(page.locator("#apply")).to_be_disabled()  # nothing left dirty

    # refused by the node's own callback: all or none, with its reason on the page
    row(page, "mode").locator('[data-role="input"]').fill("bogus")
    row(page, "limits.count").locator('[data-role="input"]').fill("8")
    page.click("#apply")
    expect(page.locator("#banner")).to_contain_text("mode must be auto or manual, not 'bogus'")
    assert host.command("get /robot/rich mode") == 'value "manual"'
    assert host.command("get /robot/rich limits.count") == "value 6"


def test_a_mirrored_node_killed_and_restarted_in_ros2_gets_a_new_incarnation(
    ros_hosts: Any, console: Console, domain_id: int
) -> None:
    """kill -9 and an immediate restart of the rclpy process: the dead participant stays in
    the ROS 2 graph for Fast DDS's lease, the bridge sees the node's new /parameter_events
    writer and resynchronizes, but kept hosting it under the same incarnation, so a monitor
    or the console could not tell the node restarted (back at its defaults). Now the mirror
    is hosted again: a new incarnation, as a restarted paramdds server has."""
    from paramdds.dds.monitor import ParameterMonitor

    dp = make_participant(domain_id, localhost=True)
    monitor = ParameterMonitor(dp)
    try:
        host = ros_hosts("--rich", "/robot/rich")
        first = wait_summary(console, "robot/rich", lambda s: s["online"])
        wait_until(lambda: getattr(monitor.snapshot().get("robot/rich"), "online", False), 20, "online")
        assert f"{monitor.snapshot()['robot/rich'].incarnation:016x}" == first["incarnation"]
        assert post(console, "set", {"node": "robot/rich", "values": {"mode": "manual"}}).status_code == 200
        host.kill()
        host = ros_hosts("--rich", "/robot/rich")  # back at its defaults (mode 'auto')
        again = wait_summary(
            console, "robot/rich", lambda s: s["online"] and s["incarnation"] != first["incarnation"], 30
        )
        wait_until(
            lambda: (
                (st := monitor.snapshot().get("robot/rich")) is not None
                and st.online
                and f"{st.incarnation:016x}" == again["incarnation"]
                and st.parameters["mode"][0].value == "auto"
            ),
            20,
            "the monitor at the new incarnation with the node's defaults",
        )
        rows = httpx.get(console.url + "api/node", params={"node": "robot/rich"}, timeout=10).json()["rows"]
        assert [r["value"] for r in rows if r["name"] == "mode"] == ["auto"]
    finally:
        monitor.close()
        close_participant(dp)


def wait_until(check: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def test_the_bridge_with_an_identity_stops_at_once_and_says_secure_mode_is_not_supported(
    ros_env: dict[str, str], tmp_path: Path
) -> None:
    """``paramdds ros2 --identity`` failed with whatever came first: in the test environment
    "secure mode needs Cyclone DDS built with security", in a secure one with rclpy the
    secure server's "created with its node ids (nodes=...)" after rclpy had started. The
    bridge cannot know its node ids up front: it now says so at once, in every environment."""
    from paramdds.secure.keystore import add_identity, init_keystore

    from ..secure.conftest import _secure_bin

    init_keystore(tmp_path / "ks")
    add_identity(tmp_path / "ks", "admin", "admin", ["*"])
    identity = str(tmp_path / "ks" / "identities" / "admin")
    commands = [[sys.executable, "-m", "paramdds.cli", "--identity", identity, "ros2"]]
    secure = _secure_bin()
    if secure is not None:  # where secure mode works: the same refusal, before rclpy is looked for
        commands.append([str(secure / "paramdds"), "--identity", identity, "ros2"])
    for command in commands:
        started = time.monotonic()
        done = subprocess.run(command, env=ros_env, capture_output=True, text=True, timeout=60, check=False)
        assert done.returncode == 2, done.stderr
        assert "the ROS 2 bridge does not run in secure mode" in done.stderr
        assert "Traceback" not in done.stderr
        assert time.monotonic() - started < 30
    by_env = subprocess.run(
        [sys.executable, "-m", "paramdds.cli", "ros2"],
        env={**ros_env, "PARAMDDS_IDENTITY": identity},
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert by_env.returncode == 2 and "does not run in secure mode" in by_env.stderr, by_env.stderr
