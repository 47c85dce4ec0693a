"""Each parameter's last change in the console (API rows and the page's column), live from its monitor.

Real console, real servers, real Cyclone; the page in real headless Chromium (conftest.py).
"""

from __future__ import annotations

import time

import httpx
import pytest
from playwright.sync_api import Page, expect

from paramdds.core.monitor_events import EventKind, MonitorEvent
from paramdds.core.results import LastChange
from paramdds.core.values import ParameterValue
from paramdds.web.view import StateView

from ._support import Console
from .test_api import post
from .test_browser import current, open_node, row
from .test_units import _streamed


def last_change(console: Console, node: str, name: str, revision: int) -> dict[str, object]:
    """The row's last change once the console's monitor holds the change at ``revision``."""
    deadline = time.monotonic() + 10
    seen: object = None
    while time.monotonic() < deadline:
        rows = httpx.get(console.url + "api/node", params={"node": node}, timeout=5).json()["rows"]
        seen = next(r["last_change"] for r in rows if r["name"] == name)
        if isinstance(seen, dict) and seen["revision"] == revision:
            return seen
        time.sleep(0.05)
    raise AssertionError(f"{node} {name}: no last change at r{revision} in 10 s (last seen: {seen})")


def test_a_change_streamed_to_the_page_carries_who_made_it() -> None:
    """The event stream's row and log line of a change carry its last change, from the monitor's event."""
    last = LastChange("carol", False, "web", 1_764_380_000_000_000_000, 7)
    change = MonitorEvent(
        EventKind.MODIFIED, "arm", "gain", ParameterValue.from_python(8), None, 7, last_change=last
    )
    params, _nodes, log = _streamed(StateView(), "arm", [change])
    assert (
        '"last_change":{"who":"carol","verified":false,"via":"web","time":"2025-11-29T01:33:20.000000Z"'
        in params
    )
    assert '"who":"carol"' in log
    plain = MonitorEvent(EventKind.MODIFIED, "arm", "gain", ParameterValue.from_python(9), None, 8)
    params, _nodes, log = _streamed(StateView(), "arm", [plain])  # a writer that keeps no blame
    assert '"last_change":null' in params and '"who":null' in log


def test_a_row_shows_who_last_changed_it(console: Console) -> None:
    rows = httpx.get(console.url + "api/node", params={"node": "base"}, timeout=5).json()["rows"]
    started = next(r["last_change"] for r in rows if r["name"] == "mode")
    assert started is not None and started["via"] == "start"  # the value the node started with
    r = post(console, "set", {"node": "base", "values": {"mode": "manual"}, "as": "carol"})
    assert r.status_code == 200, r.text
    blame = last_change(console, "base", "mode", r.json()["revision"])
    assert (blame["who"], blame["via"], blame["verified"]) == ("carol", "web", False)
    assert str(blame["time"]).endswith("Z")


@pytest.mark.slow
def test_the_page_shows_the_last_change_of_a_set_made_as_the_operator(page: Page, console: Console) -> None:
    open_node(page, console, "arm")
    page.fill("#operator", "dave")
    field = row(page, "gain").locator('[data-role="input"]')
    field.fill("3")
    field.press("Enter")
    expect(current(page, "gain")).to_have_text("3")
    last = row(page, "gain").locator("td.last")
    expect(last.locator(".who")).to_have_text("dave")
    expect(last.locator(".claimed")).to_have_text("claimed")  # the console's word, not verified by the node
    expect(last).to_contain_text("web · r")
    post(console, "set", {"node": "arm", "values": {"gain": 4}, "as": "erin"}).raise_for_status()
    expect(last.locator(".who")).to_have_text("erin")  # live: another's change shows at once
    expect(page.locator("#log")).to_contain_text("arm gain = 4 by erin")
