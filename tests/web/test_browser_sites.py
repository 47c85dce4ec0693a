"""The console over Zenoh lists the sites it lacks: a real router on loopback, real gateways
and servers, ``paramdds web`` over Zenoh, its API and the page in headless Chromium.

A site named but not connected is a row ``SITE/*`` (``no answer``) in ``/api/nodes``'s
``missing`` and on the page; when it connects its nodes replace the row, and a site whose
gateway stops shows its row again, each without a reload (the event stream's refresh).
"""

from __future__ import annotations

import json
import re
import time
import urllib.request
from collections.abc import Callable

import pytest
from playwright.sync_api import Page, expect

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from ..zenoh.conftest import Fleet, free_port  # skips the module without the zenoh extra

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

OFFLINE = re.compile(r"\boffline\b")



def until(check: Callable[[], object], timeout: float = 15.0) -> object:
    """``check()`` once it is truthy (an AssertionError naming its last value otherwise)."""
    deadline = time.monotonic() + timeout
    while True:
        got = check()
        if got or time.monotonic() > deadline:
            assert got, f"not true within {timeout} s: {got!r}"
            return got
        time.sleep(0.1)


def test_a_site_lacking_is_a_row_kept_current_in_the_api_and_on_the_page(fleet: Fleet, page: Page) -> None:
    fleet.server("s1", "robot1")
    s1 = fleet.gateway("s1")
    port = free_port()
    env = make_dds_env(fleet.domain("s1") + 1, PARAMDDS_ZENOH=fleet.endpoint, PARAMDDS_ZENOH_SITES="s1,east")
    web = Proc([PARAMDDS, "web", "--bind", f"127.0.0.1:{port}"], env)
    fleet.procs.append(web)
    web.wait_for("[WEB] Console on", 30)
    url = f"http://127.0.0.1:{port}/"

    def listed() -> tuple[dict[str, bool], dict[str, str]]:
        with urllib.request.urlopen(url + "api/nodes", timeout=5) as r:
            body = json.loads(r.read())
        nodes = {n["node"]: n["online"] for n in body["nodes"]}
        return nodes, {m["site"]: m["status"] for m in body["missing"]}

    # east is named (PARAMDDS_ZENOH_SITES) but has no gateway: a row, "no answer", with why
    until(lambda: listed() == ({"s1/robot1": True}, {"east": "no answer"}))
    page.goto(url)
    east = page.locator('#nodes li[data-site="east"]')
    expect(east).to_contain_text("east/*")
    expect(east.locator(".status")).to_have_text("no answer")
    expect(east).to_have_class("offline lacking")
    assert "no gateway of site 'east' is reachable" in (east.get_attribute("title") or "")
    expect(page.locator('#nodes li[data-node="s1/robot1"]')).not_to_have_class(OFFLINE)
    expect(page.locator("#node-count")).to_have_text("1 node · 1 site lacking")
    expect(page.locator("#stream-state")).to_have_text("live")

    # east connects: its node replaces its row, on the page as it is
    fleet.server("east", "robot1")
    fleet.gateway("east")
    until(lambda: listed() == ({"east/robot1": True, "s1/robot1": True}, {}))
    expect(east).to_have_count(0)
    expect(page.locator('#nodes li[data-node="east/robot1"]')).not_to_have_class(OFFLINE)
    expect(page.locator("#node-count")).to_have_text("2 nodes")

    # s1's gateway stops: s1 is lacking again, a row above its node shown offline
    s1.stop()
    until(lambda: listed() == ({"east/robot1": True, "s1/robot1": False}, {"s1": "no answer"}))
    expect(page.locator('#nodes li[data-site="s1"]')).to_contain_text("s1/*")
    expect(page.locator('#nodes li[data-node="s1/robot1"]')).to_have_class(OFFLINE)
    expect(page.locator("#node-count")).to_have_text("2 nodes · 1 site lacking")
