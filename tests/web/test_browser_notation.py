"""The console in headless Chromium against a real server: an open-ended range shows as open,
with no slider; a string array is shown and edited in one notation (JSON)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Page, expect

from ..cli._support import Proc, start_server
from ._support import Console
from .conftest import wait_for_nodes
from .test_browser import cli_value, current, open_node, row

pytestmark = pytest.mark.slow

OPEN = """\
/**:
  ros__parameters:
    reach: 1.5
    floor: -2.0
    count: 3
    speed: 1.0
    topics: ["/scan", "it's"]
  paramdds__descriptors:
    reach:
      type: double
      floating_point_range: [0.0, 1.7976931348623157e+308, 0.0]
    floor:
      type: double
      floating_point_range: [-.inf, 0.0, 0.0]
    count:
      type: integer
      integer_range: [1, 9223372036854775807, 1]
    speed:
      type: double
      floating_point_range: [0.0, 5.0, 0.0]
"""


@pytest.fixture(scope="module")
def open_node_server(
    domain: int, console: Console, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Proc]:
    path: Path = tmp_path_factory.mktemp("open") / "open.yaml"
    path.write_text(OPEN)
    proc = start_server(domain, "-n", "wide", "-p", str(path))
    wait_for_nodes(console.url, {"wide"}, params=5)
    yield proc
    proc.stop()


def test_an_open_ended_range_shows_open_without_a_slider(
    page: Page, console: Console, open_node_server: Proc
) -> None:
    open_node(page, console, "wide")
    expect(row(page, "reach").locator(".constraints")).to_have_text("≥ 0.0")
    expect(row(page, "floor").locator(".constraints")).to_have_text("≤ 0.0")
    expect(row(page, "count").locator(".constraints")).to_have_text("≥ 1 step 1")
    for name in ("reach", "floor", "count"):
        expect(row(page, name).locator('[data-role="slider"]')).to_have_count(0)
    expect(row(page, "speed").locator(".constraints")).to_have_text("[0.0, 5.0]")
    expect(row(page, "speed").locator('[data-role="slider"]')).to_have_count(1)
    expect(page.locator("#params")).not_to_contain_text("1.7976931348623157e+308")


def test_a_string_array_is_shown_as_it_is_edited(
    page: Page, console: Console, domain: int, open_node_server: Proc
) -> None:
    open_node(page, console, "wide")
    shown = '["/scan", "it\'s"]'
    expect(current(page, "topics")).to_have_text(shown)
    field = row(page, "topics").locator('[data-role="input"]')
    expect(field).to_have_value(shown)
    field.fill('["/scan", "/imu"]')
    field.press("Enter")
    expect(current(page, "topics")).to_have_text('["/scan", "/imu"]')
    expect(field).to_have_value('["/scan", "/imu"]')
    assert cli_value(domain, "wide", "topics") == "['/scan', '/imu']"
