"""The page's answers to the second round of operator findings (issue 21), in headless
Chromium against a real console and real servers. Each test failed before its fix."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Page, expect

from ..cli._support import Proc, run_cli, start_server
from ._support import Console
from .conftest import wait_for_nodes
from .test_api import post, value_of
from .test_browser import cli_value, current, open_node, row

BIG = 2**53 + 1  # the first integer a JavaScript number cannot hold


@pytest.fixture(scope="module")
def big(domain: int, console: Console, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Proc]:
    """A node ``big`` holding integers beyond 2^53."""
    path: Path = tmp_path_factory.mktemp("big") / "big.yaml"
    path.write_text(f"/**:\n  ros__parameters:\n    huge: {BIG}\n    huges: [{BIG}, -{BIG}, 1]\n")
    proc = start_server(domain, "-n", "big", "-p", str(path))
    wait_for_nodes(console.url, {"big"}, params=2)
    yield proc
    proc.stop()


def test_the_pages_own_write_moves_the_base_of_the_other_edits(
    page: Page, console: Console, domain: int
) -> None:
    """Item 2: edit two rows, apply one with Enter, then the other atomically: applied, not
    "changed meanwhile" (the page's own write is no conflict)."""
    open_node(page, console, "arm")
    row(page, "speed").locator('[data-role="input"]').fill("3.5")
    gain = row(page, "gain").locator('[data-role="input"]')
    gain.fill("6")
    expect(page.locator("#apply")).to_have_text("Apply 2 changes atomically")
    gain.press("Enter")
    expect(current(page, "gain")).to_have_text("6")
    expect(page.locator("#apply")).to_have_text("Apply 1 change atomically")
    page.click("#apply")
    expect(page.locator("#banner")).to_contain_text("Applied 1 changes atomically")
    expect(current(page, "speed")).to_have_text("3.5")
    assert cli_value(domain, "arm", "speed") == "3.5" and cli_value(domain, "arm", "gain") == "6"


def test_an_error_banner_has_no_null_line(page: Page, console: Console) -> None:
    """Item 4."""
    open_node(page, console, "arm")
    row(page, "gain").locator('[data-role="input"]').fill("x")
    row(page, "speed").locator('[data-role="input"]').fill("1.0")
    page.click("#apply")
    banner = page.locator("#banner")
    expect(banner).to_have_text("Not sent: gain is not valid.")  # the whole text: no "null"
    expect(banner).not_to_contain_text("null")


def test_integers_beyond_2_53_are_shown_and_edited_exactly(
    page: Page, console: Console, domain: int, big: Proc
) -> None:
    """Item 5: shown rounded (9007199254740992) before; an edit must not round either."""
    open_node(page, console, "big")
    expect(current(page, "huge")).to_have_text(str(BIG))
    expect(row(page, "huge").locator('[data-role="input"]')).to_have_value(str(BIG))
    expect(current(page, "huges")).to_have_text(f"[{BIG}, -{BIG}, 1]")
    field = row(page, "huge").locator('[data-role="input"]')
    field.fill(str(BIG + 2))
    field.press("Enter")
    expect(current(page, "huge")).to_have_text(str(BIG + 2))
    assert cli_value(domain, "big", "huge") == str(BIG + 2)
    field = row(page, "huges").locator('[data-role="input"]')
    field.fill(f"[{BIG + 4}, 2]")
    field.press("Enter")
    expect(current(page, "huges")).to_have_text(f"[{BIG + 4}, 2]")
    assert value_of(console, "big", "huges") == [BIG + 4, 2]
    field = row(page, "huge").locator('[data-role="input"]')
    field.fill(str(2**63))
    expect(row(page, "huge").locator(".error")).to_contain_text("64-bit")


def test_a_long_value_and_a_long_log_line_stay_inside_the_page(page: Page, console: Console) -> None:
    """Item 6: 100 kB without spaces made the table 843,391 px wide."""
    open_node(page, console, "base")
    assert post(console, "set", {"node": "base", "values": {"note": "x" * 100_000}}).status_code == 200
    expect(current(page, "note")).to_contain_text("xxxx")
    expect(page.locator("#log li").first).to_contain_text("base note")
    sizes = page.evaluate(
        """() => ({page: document.documentElement.scrollWidth, view: window.innerWidth,
                   table: document.querySelector('#params').scrollWidth,
                   detail: document.querySelector('#detail').clientWidth,
                   log: document.querySelector('footer').scrollWidth,
                   footer: document.querySelector('footer').clientWidth})"""
    )
    assert sizes["page"] <= sizes["view"], sizes
    assert sizes["table"] <= sizes["detail"], sizes
    assert sizes["log"] <= sizes["footer"], sizes
    assert post(console, "set", {"node": "base", "values": {"note": "scratch"}}).status_code == 200


def test_control_and_bidirectional_characters_show_and_multi_line_strings_edit(
    page: Page, console: Console
) -> None:
    """Item 7: U+202E showed 'gnp.exe' as 'exe.png'; newlines were collapsed, and the one-line
    editor saved a multi-line string without them."""
    open_node(page, console, "base")
    assert post(console, "set", {"node": "base", "values": {"note": "\u202egnp.exe"}}).status_code == 200
    expect(current(page, "note")).to_have_text("'\\u202egnp.exe'")  # as the node's repr writes it
    assert "\u202e" not in current(page, "note").inner_text()
    assert post(console, "set", {"node": "base", "values": {"note": "one\ntwo"}}).status_code == 200
    expect(current(page, "note")).to_have_text("'one\\ntwo'")
    editor = row(page, "note").locator("textarea")
    expect(editor).to_have_value("one\ntwo")
    editor.fill("one\ntwo\nthree")
    editor.press("Enter")  # a new line, not a submit
    row(page, "note").locator("button.set").click()
    expect(current(page, "note")).to_have_text("'one\\ntwo\\nthree\\n'")
    assert value_of(console, "base", "note") == "one\ntwo\nthree\n"
    assert post(console, "set", {"node": "base", "values": {"note": "scratch"}}).status_code == 200


@pytest.mark.parametrize(
    ("name", "text", "cli"),
    [
        ("limits", "[1.0, 11.0]", "limits=[1.0, 11.0]"),  # element_bounds
        ("tags", '["front", "front"]', "tags=[front, front]"),  # unique
    ],
)
def test_the_pages_own_checks_word_their_refusals_as_the_node(
    page: Page, console: Console, domain: int, name: str, text: str, cli: str
) -> None:
    """Item 8: the browser's message is the node's, word for word."""
    open_node(page, console, "arm")
    row(page, name).locator('[data-role="input"]').fill(text)
    message = row(page, name).locator(".error")
    expect(message).not_to_have_text("")
    direct = run_cli(domain, "set", "arm", cli)
    assert direct.returncode == 1
    reason = direct.stdout.split("FAILED: ", 1)[1].splitlines()[0]  # "tags: FAILED: <the reason>"
    assert message.inner_text() == reason


def test_a_bad_or_unknown_node_in_the_link_leaves_the_page_working(page: Page, console: Console) -> None:
    """Item 9: a malformed fragment threw in start() (the page stayed "connecting…"), an
    unknown node id stayed "reconnecting…"."""
    for fragment in ("#node=%E0%A4%A", "#node=no%20such%20node"):
        page.goto(console.url + fragment)
        expect(page.locator("#stream-state")).to_have_text("live")
        expect(page.locator("#empty")).to_be_visible()
        expect(page.locator("#empty")).to_contain_text("no")
        expect(page.locator("#nodes li").first).to_be_visible()  # the list works
    page.goto(console.url + "#node=ghost")  # a valid id no node has (yet)
    expect(page.locator("#stream-state")).to_have_text("live")
    expect(page.locator("#node-meta")).to_contain_text("unknown to this console")


def test_doubles_in_the_log_keep_their_point_and_no_request_is_a_404(
    page: Page, console: Console, domain: int
) -> None:
    """Item 11: the log showed 2.0 as 2; favicon.ico was a 404 on every load."""
    missing: list[str] = []
    page.on("response", lambda r: missing.append(r.url) if r.status == 404 else None)
    open_node(page, console, "arm")
    assert run_cli(domain, "set", "arm", "speed=2.0").returncode == 0
    expect(page.locator("#log")).to_contain_text("arm speed = 2.0")
    page.reload()
    expect(page.locator("#stream-state")).to_have_text("live")
    page.wait_for_timeout(300)
    assert missing == []
