"""The page with hard values and restarts, in headless Chromium against a real console and
real servers: its own writes and the others' edits, integers beyond 2**53, long and
unprintable text, its own refusals worded as the node's, a bad link, a restart, a node
mirrored from ROS 2, and the token asked for off loopback."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Page, expect

from ..cli._support import Proc, run_cli, start_server
from ._support import CONSOLE_PARAMS, Console
from .conftest import wait_for_nodes
from .test_api import post, value_of
from .test_browser import cli_value, current, open_node, row

pytestmark = pytest.mark.slow

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
    """Item 4. Apply is disabled while an edit shows its error, so the banner is what a click
    made before the console's answer gets: the edit and the click in one task of the page."""
    open_node(page, console, "arm")
    row(page, "speed").locator('[data-role="input"]').fill("1.0")
    page.evaluate(
        """() => {
          const gain = document.querySelector('#params tr[data-name="gain"] [data-role="input"]');
          gain.value = "11";
          gain.dispatchEvent(new Event("input"));
          document.querySelector("#apply").click();
        }"""
    )
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
def test_the_page_words_its_refusals_as_the_node(
    page: Page, console: Console, domain: int, name: str, text: str, cli: str
) -> None:
    """The browser's message is the node's, word for word: the console validates each edit
    with the core's validation (POST /api/validate), the page holds no copy of the rules."""
    open_node(page, console, "arm")
    row(page, name).locator('[data-role="input"]').fill(text)
    message = row(page, name).locator(".error")
    expect(message).not_to_have_text("")
    direct = run_cli(domain, "set", "arm", cli)
    assert direct.returncode == 1
    reason = direct.stdout.split("FAILED: ", 1)[1].splitlines()[0]  # "tags: FAILED: <the reason>"
    assert message.inner_text() == reason


def test_an_edit_is_checked_by_the_server_and_a_refused_one_is_never_set(
    page: Page, console: Console, domain: int
) -> None:
    """As the user types, the page asks the console (debounced) and shows its reason; while
    the reason is shown, Enter (and the Set button) send nothing to the node."""
    sent: list[str] = []
    page.on("request", lambda r: sent.append(r.url.rsplit("/", 1)[-1]) if r.method == "POST" else None)
    open_node(page, console, "arm")
    field = row(page, "gain").locator('[data-role="input"]')
    field.fill("11")  # integer_range [0, 10, 1]
    message = row(page, "gain").locator(".error")
    expect(message).to_contain_text("must be within")
    assert sent and set(sent) == {"validate"}
    field.press("Enter")
    row(page, "gain").locator("button.set").click()
    page.wait_for_timeout(300)
    assert "set" not in sent
    expect(message).to_contain_text("must be within")
    assert cli_value(domain, "arm", "gain") == current(page, "gain").inner_text()
    field.fill("7")
    expect(message).to_have_text("")
    field.press("Enter")
    expect(current(page, "gain")).to_have_text("7")
    assert "set" in sent


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


def test_after_a_restart_the_page_applies_atomically_again(page: Page, console: Console, domain: int) -> None:
    """The page once kept the highest revision after the node came back at its start
    revision, and every "Apply atomically" answered "changed meanwhile"."""
    first = start_server(domain, "-n", "lazarus", "-p", str(CONSOLE_PARAMS))
    try:
        wait_for_nodes(console.url, {"lazarus"})
        open_node(page, console, "lazarus")
        start = int(page.locator("#node-meta").get_attribute("data-revision") or 0)
        for gain in ("1", "2"):
            field = row(page, "gain").locator('[data-role="input"]')
            field.fill(gain)
            field.press("Enter")
            expect(current(page, "gain")).to_have_text(gain)
        expect(page.locator("#node-meta")).to_have_attribute("data-revision", str(start + 2))
        old = page.locator("#node-meta").get_attribute("data-incarnation")
    finally:
        first.popen.send_signal(signal.SIGKILL)
        first.stop()
    expect(page.locator("#node-view")).to_have_class("offline")
    again = start_server(domain, "-n", "lazarus", "-p", str(CONSOLE_PARAMS))
    try:
        expect(page.locator("#node-view")).not_to_have_class("offline")
        expect(page.locator("#node-meta")).not_to_have_attribute("data-incarnation", old or "")
        expect(page.locator("#node-meta")).to_have_attribute("data-revision", str(start))
        row(page, "gain").locator('[data-role="input"]').fill("7")
        page.click("#apply")
        expect(page.locator("#banner")).to_contain_text("Applied 1 changes atomically")
        assert cli_value(domain, "lazarus", "gain") == "7"
    finally:
        again.stop()


def test_a_node_mirrored_from_ros2_is_marked(page: Page, console: Console, domain: int) -> None:
    """A presence tagged origin=ros2 (the bridge's mirrored nodes) shows a mark in the list and
    the node's line, and "origin" in the API; so does its status (stale: a set waits on it)."""
    from cyclonedds.pub import DataWriter

    from paramdds.dds.participant import close_participant, make_participant
    from paramdds.dds.qos import QosProfiles
    from paramdds.dds.topics import make_topic
    from paramdds.dds.wire import types as wire

    dp = make_participant(domain, localhost=True)
    try:
        writer = DataWriter(
            dp,
            make_topic(dp, "ParameterEvents", wire.ParameterEvent),
            QosProfiles.load().writer("ParameterEvents"),
        )
        tags = wire.ParameterValue(
            type=9, string_array_value=["request_filter=handler", "origin=ros2", "status=stale"]
        )
        writer.write(
            wire.ParameterEvent(
                node_id="talker",
                name="use_sim_time",
                kind=0,
                revision=1,
                value=wire.ParameterValue(type=1),
                incarnation=7,
            )
        )
        writer.write(
            wire.ParameterEvent(
                node_id="talker",
                name="",
                kind=1,
                revision=1,
                host="ros",
                pid=1,
                parameter_count=1,
                value=tags,
                incarnation=7,
            )
        )
        wait_for_nodes(console.url, {"talker"}, params=1)
        listed = [
            n
            for n in httpx.get(console.url + "api/nodes", timeout=5).json()["nodes"]
            if n["node"] == "talker"
        ]
        assert [(n["origin"], n["status"]) for n in listed] == [("ros2", "stale")]
        assert all(
            n["origin"] is None and n["status"] is None
            for n in httpx.get(console.url + "api/nodes", timeout=5).json()["nodes"]
            if n["node"] != "talker"
        )
        page.goto(f"{console.url}#node=/talker")  # accepted with its leading slash, as ROS 2 writes it
        expect(page.locator("#node-name")).to_have_text("/talker")  # and shown with it
        expect(page.locator('#nodes li[data-node="talker"] .n')).to_contain_text("/talker")
        expect(page.locator('#nodes li[data-node="talker"] .origin')).to_have_text("ros2")
        expect(page.locator('#nodes li[data-node="arm"] .origin')).to_have_count(0)
        expect(page.locator('#nodes li[data-node="talker"] .status')).to_have_text("stale")
        expect(page.locator('#nodes li[data-node="arm"] .status')).to_have_count(0)
        expect(page.locator("#node-meta")).to_contain_text("mirrored from ros2 · stale")
    finally:
        close_participant(dp)


def test_off_loopback_the_page_asks_for_the_token_before_reading(
    page: Page, domain: int, servers: Proc, tmp_path: Path
) -> None:
    """Security: a console other machines can reach reads nothing without the token; the page
    asks for it first, then lists the nodes and streams (the stream sends it as a cookie)."""
    from ._support import write_token

    token = "page-token-for-reads-0123456"
    remote = Console(domain, "--bind", "0.0.0.0:0", "--token-file", str(write_token(tmp_path, token)))
    try:
        page.goto(remote.url.replace("0.0.0.0", "127.0.0.1") + "#node=arm")
        expect(page.locator("#stream-state")).to_have_text("needs the token")
        expect(page.locator("#token-box")).to_be_visible()
        expect(page.locator("#nodes li")).to_have_count(0)
        page.fill("#token", token)
        page.locator("#token").dispatch_event("change")
        expect(page.locator("#stream-state")).to_have_text("live")
        expect(page.locator('#nodes li[data-node="arm"]')).to_be_visible()
        expect(row(page, "gain")).to_be_visible()
    finally:
        remote.stop()
