"""The console in real headless Chromium (Debian's ``chromium``, driven by Playwright).

One browser for the module, one console and two nodes (``arm``, ``base``) shared
by the tests; a test that stops a server starts its own. A failing test leaves
a screenshot of the page in its pytest output directory (see conftest.py).
"""

from __future__ import annotations

import re
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Locator, Page, expect

from ..cli._support import ROOT, run_cli, start_server
from ._support import CONSOLE_PARAMS, Console, write_token
from .conftest import wait_for_nodes

pytestmark = pytest.mark.slow


def row(page: Page, name: str) -> Locator:
    return page.locator(f'#params tbody tr[data-name="{name}"]')


def open_node(page: Page, console: Console, node: str) -> None:
    page.goto(f"{console.url}#node={node}")
    expect(page.locator("#node-name")).to_have_text(node)
    expect(page.locator("#params tbody tr").first).to_be_visible()
    expect(page.locator("#stream-state")).to_have_text("live")


def current(page: Page, name: str) -> Locator:
    return row(page, name).locator(".current")


def cli_value(domain: int, node: str, name: str) -> str:
    """The value as the node holds it, written as the page shows it (``2.5``, ``'auto'``)."""
    out = run_cli(domain, "get", node, name)
    assert out.returncode == 0, out.stderr
    typed = out.stdout.strip().split(" = ", 1)[1]  # "double 2.5"
    return typed.split(" ", 1)[1]


def test_lists_both_nodes_online(page: Page, console: Console) -> None:
    page.goto(console.url)
    items = page.locator("#nodes li")
    expect(items).to_have_count(2)
    expect(items.nth(0)).to_have_attribute("data-node", "arm")
    expect(items.nth(1)).to_have_attribute("data-node", "base")
    expect(items.nth(0)).to_contain_text("9 params")
    expect(items.nth(0)).not_to_have_class("offline")
    expect(page.locator("#node-count")).to_have_text("2 nodes")


def test_search_filters_nodes_and_parameter_names(page: Page, console: Console) -> None:
    open_node(page, console, "arm")
    page.fill("#search", "bas")
    expect(page.locator("#nodes li")).to_have_count(1)
    page.fill("#search", "gain")
    expect(page.locator("#nodes li")).to_have_count(2)
    expect(row(page, "gain")).to_be_visible()
    expect(row(page, "speed")).to_be_hidden()


def test_in_range_double_edit_is_applied_and_survives_a_reload(
    page: Page, console: Console, domain: int
) -> None:
    open_node(page, console, "arm")
    field = row(page, "speed").locator('[data-role="input"]')
    field.fill("2.5")
    field.press("Enter")
    expect(current(page, "speed")).to_have_text("2.5")
    expect(row(page, "speed").locator(".error")).to_have_text("")
    assert cli_value(domain, "arm", "speed") == "2.5"
    page.reload()
    expect(current(page, "speed")).to_have_text("2.5")


def test_out_of_range_shows_the_nodes_reason_and_changes_nothing(
    page: Page, console: Console, domain: int
) -> None:
    open_node(page, console, "arm")
    before = cli_value(domain, "arm", "speed")
    revision = page.locator("#node-meta").get_attribute("data-revision")
    field = row(page, "speed").locator('[data-role="input"]')
    field.fill("9.5")
    field.press("Enter")
    message = row(page, "speed").locator(".error")
    expect(message).to_contain_text("must be within")
    # the words are the node's own: what it answers when asked directly
    direct = run_cli(domain, "set", "arm", "speed=9.5")
    assert direct.returncode == 1 and message.inner_text() in direct.stderr
    expect(current(page, "speed")).to_have_text(before)
    assert cli_value(domain, "arm", "speed") == before
    expect(page.locator("#node-meta")).to_have_attribute("data-revision", str(revision))


def test_a_refusal_by_the_node_is_shown_under_the_field(page: Page, console: Console, domain: int) -> None:
    frozen = start_server(domain, "-n", "frozen", "--read-only", "-p", str(CONSOLE_PARAMS))
    try:
        wait_for_nodes(console.url, {"frozen"})
        open_node(page, console, "frozen")
        field = row(page, "gain").locator('[data-role="input"]')
        field.fill("3")  # valid by the descriptor: only the node (served --read-only) refuses it
        field.press("Enter")
        message = row(page, "gain").locator(".error")
        expect(message).not_to_have_text("")
        direct = run_cli(domain, "set", "frozen", "gain=3")
        assert direct.returncode == 1 and message.inner_text() in direct.stderr
        expect(current(page, "gain")).to_have_text("4")
    finally:
        frozen.stop()


@pytest.fixture(scope="module")
def cruise(domain: int, console: Console) -> Iterator[None]:
    """A node ``cruise`` declared by a JSON Schema (examples/autoware), which its server enforces."""
    example = ROOT / "examples" / "autoware"
    schema, values = example / "schema" / "cruise.schema.json", example / "config" / "cruise.param.yaml"
    server = start_server(domain, "-n", "cruise", "--schema", str(schema), "-p", str(values))
    try:
        wait_for_nodes(console.url, {"cruise"}, params=6)
        yield
    finally:
        server.stop()


def test_a_json_schema_enum_is_edited_with_a_choice_list(
    page: Page, console: Console, domain: int, cruise: None
) -> None:
    """The schema's ``enum`` (``mode``: eco or sport) reaches the descriptor as the text
    ``one of [...]``; the editor offers those values as a ``one_of``'s are offered, instead of
    a text field that takes anything."""
    open_node(page, console, "cruise")
    mode = row(page, "mode").locator('[data-role="input"]')
    expect(row(page, "mode").locator("select option")).to_have_text(["eco", "sport"])
    expect(mode).to_have_value("eco")
    mode.select_option("sport")
    row(page, "mode").locator("button.set").click()
    expect(current(page, "mode")).to_have_text("'sport'")
    assert cli_value(domain, "cruise", "mode") == "'sport'"
    expect(row(page, "max_speed").locator("select")).to_have_count(0)  # no enum: a text field


def test_a_choice_list_shows_a_value_held_outside_it(
    page: Page, console: Console, domain: int, tmp_path: Path
) -> None:
    """``one of [...]`` written by hand among a descriptor's constraints is text the node does
    not enforce: the value it holds outside the list is shown and kept, not the first choice."""
    params = tmp_path / "loose.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    level: c\n  paramdds__descriptors:\n    level:\n"
        "      type: string\n      additional_constraints: 'one of [\"a\", \"b\"]'\n"
    )
    server = start_server(domain, "-n", "loose", "-p", str(params))
    try:
        wait_for_nodes(console.url, {"loose"}, params=1)
        open_node(page, console, "loose")
        expect(row(page, "level").locator("select option")).to_have_text(["c", "a", "b"])
        expect(row(page, "level").locator('[data-role="input"]')).to_have_value("c")
    finally:
        server.stop()


def test_apply_comes_back_once_an_atomic_set_the_node_refused_is_corrected(
    page: Page, console: Console, domain: int, cruise: None
) -> None:
    """The node (not the console, which has no --schema here) refuses the combination: each
    field shows its part (the cause, and "not applied" on the other), Apply is held back, and
    correcting the cause brings it back: the other's "not applied" was about the old one."""
    open_node(page, console, "cruise")
    apply = page.locator("#apply")
    row(page, "max_speed").locator('[data-role="input"]').fill("20.0")
    rate = row(page, "update_rate").locator('[data-role="input"]')
    rate.fill("0.0")  # in the descriptor's range; the schema's exclusiveMinimum refuses it
    expect(apply).to_be_enabled()
    apply.click()
    expect(row(page, "update_rate").locator(".error")).to_contain_text("minimum")
    expect(row(page, "max_speed").locator(".error")).to_contain_text("not applied")
    expect(apply).to_be_disabled()
    rate.fill("5.0")
    expect(row(page, "max_speed").locator(".error")).to_have_text("")
    expect(row(page, "update_rate").locator(".error")).to_have_text("")
    expect(apply).to_be_enabled()
    apply.click()
    expect(page.locator("#banner")).to_contain_text("Applied 2 changes atomically")
    assert cli_value(domain, "cruise", "update_rate") == "5.0"
    assert cli_value(domain, "cruise", "max_speed") == "20.0"


def test_read_only_parameter_has_a_lock_and_no_editor(page: Page, console: Console) -> None:
    open_node(page, console, "arm")
    expect(row(page, "speed").locator('[data-role="input"]')).to_have_count(1)
    expect(row(page, "serial").locator(".lock")).to_be_visible()
    expect(row(page, "serial").locator('[data-role="input"]')).to_have_count(0)
    expect(row(page, "serial").locator("button")).to_have_count(0)


def test_apply_atomically_is_disabled_while_an_edit_shows_an_error(page: Page, console: Console) -> None:
    """Apply atomically is held back, with the reason in its title, while a pending edit shows
    an error (the notation's, or the console's verdict), and comes back once it is fixed."""
    open_node(page, console, "arm")
    apply = page.locator("#apply")
    row(page, "speed").locator('[data-role="input"]').fill("3.0")
    expect(apply).to_be_enabled()
    gain = row(page, "gain").locator('[data-role="input"]')
    gain.fill("11")  # integer_range [0, 10, 1]: refused by the console's check
    expect(row(page, "gain").locator(".error")).to_contain_text("must be within")
    expect(apply).to_be_disabled()
    expect(apply).to_have_attribute("title", re.compile(r"gain shows an error"))
    gain.fill("x")  # the notation's error
    expect(row(page, "gain").locator(".error")).to_contain_text("expected an integer")
    expect(apply).to_be_disabled()
    gain.fill("7")
    expect(row(page, "gain").locator(".error")).to_have_text("")
    expect(apply).to_be_enabled()
    expect(apply).to_have_attribute("title", re.compile(r"all or none"))
    page.click("#discard")


def test_typed_editors(page: Page, console: Console) -> None:
    open_node(page, console, "arm")
    expect(row(page, "enabled").locator('input[type="checkbox"]')).to_have_count(1)
    expect(row(page, "mode").locator("select option")).to_have_text(["auto", "manual", "off"])
    expect(row(page, "gain").locator('input[type="range"]')).to_have_attribute("max", "10")
    key = row(page, "key").locator('[data-role="input"]')
    expect(key).to_have_value("01 02 ab")
    key.fill("0g")
    expect(row(page, "key").locator(".error")).to_contain_text("hex")
    limits = row(page, "limits").locator('[data-role="input"]')
    limits.fill('[1.0, "x"]')
    expect(row(page, "limits").locator(".error")).to_contain_text("is not a double")


def test_a_cli_set_appears_without_a_reload(page: Page, console: Console, domain: int) -> None:
    open_node(page, console, "base")
    page.evaluate("window.__sameDocument = true")
    assert run_cli(domain, "set", "base", "gain=7").returncode == 0
    expect(current(page, "gain")).to_have_text("7")
    assert page.evaluate("window.__sameDocument") is True
    expect(page.locator("#log")).to_contain_text("base gain = 7")


def test_killing_a_server_greys_its_node(page: Page, console: Console, domain: int) -> None:
    doomed = start_server(domain, "-n", "doomed", "-p", str(CONSOLE_PARAMS))
    try:
        open_node(page, console, "doomed")
        item = page.locator('#nodes li[data-node="doomed"]')
        expect(item).not_to_have_class("offline")
        doomed.popen.send_signal(signal.SIGKILL)
        doomed.popen.wait(10)
        expect(item).to_have_class("offline selected")
        expect(page.locator("#node-view")).to_have_class("offline")
        expect(current(page, "gain")).to_have_text("4")  # last values kept
    finally:
        doomed.stop()


def test_stale_atomic_edit_is_refused_and_the_newer_values_shown(
    page: Page, console: Console, domain: int
) -> None:
    open_node(page, console, "arm")
    row(page, "speed").locator('[data-role="input"]').fill("1.0")
    row(page, "gain").locator('[data-role="input"]').fill("2")
    expect(page.locator("#apply")).to_have_text("Apply 2 changes atomically")
    speed, gain = cli_value(domain, "arm", "speed"), cli_value(domain, "arm", "gain")
    assert run_cli(domain, "set", "arm", "mode=manual").returncode == 0  # someone else, meanwhile
    expect(current(page, "mode")).to_have_text("'manual'")
    page.click("#apply")
    expect(page.locator("#banner")).to_contain_text("changed meanwhile")
    expect(current(page, "speed")).to_have_text(speed)
    expect(current(page, "gain")).to_have_text(gain)
    expect(row(page, "gain").locator('[data-role="input"]')).to_have_value(gain)
    assert (cli_value(domain, "arm", "speed"), cli_value(domain, "arm", "gain")) == (speed, gain)
    # positive control: the same edit, started from the newer revision, applies
    row(page, "gain").locator('[data-role="input"]').fill("2")
    page.click("#apply")
    expect(page.locator("#banner")).to_contain_text("Applied 1 changes atomically")
    assert cli_value(domain, "arm", "gain") == "2"


@pytest.fixture
def read_only_console(domain: int, console: Console) -> Iterator[Console]:
    ro = Console(domain, "--read-only")
    try:
        wait_for_nodes(ro.url, {"arm"})
        yield ro
    finally:
        ro.stop()


def test_read_only_console_offers_no_editor(page: Page, read_only_console: Console) -> None:
    open_node(page, read_only_console, "arm")
    expect(page.locator("#mode")).to_have_text("read-only console")
    expect(row(page, "speed")).to_be_visible()
    expect(page.locator('#params [data-role="input"]')).to_have_count(0)
    expect(page.locator("#apply")).to_be_hidden()


def test_dump_downloads_a_file_and_load_reports_each_parameter(
    page: Page, console: Console, tmp_path: Path
) -> None:
    open_node(page, console, "base")
    with page.expect_download() as download:
        page.click("#dump")
    assert download.value.suggested_filename == "base.yaml"
    assert "ros__parameters" in Path(download.value.path()).read_text()
    upload = tmp_path / "base.yaml"
    upload.write_text("base:\n  ros__parameters:\n    gain: 8\n    speed: 11.0\n")
    page.set_input_files("#load", str(upload))
    banner = page.locator("#banner")
    expect(banner).to_contain_text("Loaded base.yaml: 1 set, 1 refused.")
    expect(banner.locator("li")).to_have_text(
        ["gain: ok", re.compile(r"speed: Parameter 'speed' .* must be within")]
    )
    expect(current(page, "gain")).to_have_text("8")


def test_token_console_asks_for_the_token_before_a_write(
    page: Page, domain: int, console: Console, tmp_path: Path
) -> None:
    token = "browser-token-0123456789"
    guarded = Console(domain, "--token-file", str(write_token(tmp_path, token)))
    try:
        wait_for_nodes(guarded.url, {"arm"})
        open_node(page, guarded, "arm")
        field = row(page, "gain").locator('[data-role="input"]')
        field.fill("1")
        field.press("Enter")
        expect(row(page, "gain").locator(".error")).to_contain_text("bearer token")
        expect(page.locator("#token")).to_be_visible()
        page.fill("#token", token)
        field.press("Enter")
        expect(row(page, "gain").locator(".error")).to_have_text("")
        expect(current(page, "gain")).to_have_text("1")
    finally:
        guarded.stop()
