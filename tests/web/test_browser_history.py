"""Who changed what, in real headless Chromium: the operator's name and a parameter's timeline.

One browser, one console and two nodes (``arm``, ``base``) for the module (conftest.py).
"""

from __future__ import annotations

import pytest
from playwright.sync_api import Page, expect

from ..cli._support import next_domain, start_server
from ..dds.helpers import DdsSession
from ._support import CONSOLE_PARAMS, Console
from .conftest import wait_for_nodes
from .test_api import post
from .test_browser import current, open_node, row

pytestmark = pytest.mark.slow


def test_a_set_made_as_the_operator_shows_in_its_timeline(page: Page, console: Console) -> None:
    post(console, "set", {"node": "arm", "values": {"gain": 5}, "as": "setup"}).raise_for_status()
    open_node(page, console, "arm")
    page.fill("#operator", "carol")
    field = row(page, "gain").locator('[data-role="input"]')
    field.fill("8")
    field.press("Enter")
    expect(current(page, "gain")).to_have_text("8")

    row(page, "gain").locator(".pname").click()
    expect(page.locator("#timeline-title")).to_have_text("History of gain")
    newest = page.locator("#timeline-list li").first
    expect(newest.locator(".who")).to_have_text("carol")
    expect(newest.locator(".change")).to_have_text("5 → 8")
    expect(newest).to_contain_text("via web")
    expect(page.locator("#timeline-list li").nth(1).locator(".change")).to_have_text("4 → 5")

    field = row(page, "gain").locator('[data-role="input"]')
    field.fill("9")
    field.press("Enter")  # the open timeline follows the change
    expect(page.locator("#timeline-list li").first.locator(".change")).to_have_text("8 → 9")

    page.reload()  # the operator's name is remembered by the browser
    expect(page.locator("#operator")).to_have_value("carol")


def test_the_timeline_shows_a_refused_write_with_its_reason(page: Page, console: Console) -> None:
    r = post(console, "set", {"node": "base", "values": {"serial": "SN-7"}, "as": "mallory"})
    assert r.status_code == 403, r.text
    open_node(page, console, "base")
    row(page, "serial").locator(".pname").click()
    refused = page.locator("#timeline-list li.refused").first
    expect(refused.locator(".who")).to_have_text("mallory")
    expect(refused.locator(".change")).to_contain_text("refused 'SN-7': ")
    expect(page.locator("#timeline-close")).to_be_visible()
    page.click("#timeline-close")
    expect(page.locator("#timeline")).to_be_hidden()


def test_the_timeline_says_when_retention_dropped_older_history(
    page: Page, console: Console, domain: int
) -> None:
    small = start_server(domain, "-n", "tiny", "-p", str(CONSOLE_PARAMS), "--history-records", "2")
    try:
        wait_for_nodes(console.url, {"tiny"})
        for gain in (1, 2, 3):
            post(console, "set", {"node": "tiny", "values": {"gain": gain}}).raise_for_status()
        open_node(page, console, "tiny")
        row(page, "gain").locator(".pname").click()
        expect(page.locator("#timeline-note")).to_contain_text("Older history was dropped by retention")
        expect(page.locator("#timeline-list li").first.locator(".change")).to_have_text("2 → 3")
    finally:
        small.stop()


def test_the_timeline_of_a_node_that_keeps_no_history_says_so(page: Page) -> None:
    from paramdds.core.table import ParameterTable

    domain = next_domain()
    with DdsSession(domain) as dds:
        table = ParameterTable("old_peer")
        table.declare("speed", 1.0)
        server = dds.server(table)
        server._histories.pop("old_peer")  # what a peer that keeps no history answers
        console = Console(domain)
        try:
            wait_for_nodes(console.url, {"old_peer"}, params=1)
            open_node(page, console, "old_peer")
            row(page, "speed").locator(".pname").click()
            expect(page.locator("#timeline-note")).to_have_text(
                "Node old_peer keeps no history (a node of an older release, or a foreign peer)."
            )
            expect(page.locator("#timeline-list li")).to_have_count(0)
        finally:
            console.stop()
