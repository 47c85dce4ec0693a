"""The node list in Chromium with more nodes than one page: the browser holds one page of 50."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from playwright.sync_api import Page, expect

from ..cli._support import start_server
from ._support import CONSOLE_PARAMS, Console
from .conftest import wait_for_nodes

pytestmark = pytest.mark.slow

NODES = [f"fleet{i:03d}" for i in range(120)]


@pytest.fixture(scope="module")
def fleet_console(domain: int) -> Iterator[Console]:
    args = [a for n in NODES for a in ("-n", n)]
    server = start_server(domain, *args, "-p", str(CONSOLE_PARAMS))
    console = Console(domain)
    try:
        wait_for_nodes(console.url, set(NODES[:50]), timeout=60)
        yield console
    finally:
        console.stop()
        server.stop()


def test_the_node_list_is_paged_and_searched_on_the_server(page: Page, fleet_console: Console) -> None:
    page.goto(fleet_console.url)
    items = page.locator("#nodes li")
    expect(page.locator("#page")).to_have_text("1\u201350 of 120")
    expect(items).to_have_count(50)
    expect(items.first).to_have_attribute("data-node", "fleet000")
    page.click("#next")
    expect(page.locator("#page")).to_have_text("51\u2013100 of 120")
    expect(items.first).to_have_attribute("data-node", "fleet050")
    page.click("#next")
    expect(items).to_have_count(20)
    expect(page.locator("#next")).to_be_disabled()
    page.fill("#search", "fleet11")
    expect(items).to_have_count(10)
    expect(page.locator("#node-count")).to_have_text("10 nodes matching 'fleet11'")
