"""The JSON API against a real console, real servers and real Cyclone on loopback.

Every write that should be refused is shown to change nothing: the node's
revision and values are read back after it. Every refusal is checked next to a
request of the same route that succeeds (the positive control).
"""

from __future__ import annotations

import json
import signal
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from ..cli._support import run_cli, start_server
from ._support import Console, write_token
from .conftest import wait_for_nodes

JSON = {"Content-Type": "application/json"}


def node(console: Console, name: str) -> dict[str, object]:
    r = httpx.get(console.url + "api/node", params={"node": name}, timeout=5)
    assert r.status_code == 200, r.text
    body: dict[str, object] = r.json()
    return body


def value_of(console: Console, name: str, param: str) -> object:
    rows = node(console, name)["rows"]
    assert isinstance(rows, list)
    return next(r["value"] for r in rows if r["name"] == param)


def revision(console: Console, name: str) -> int:
    summary = node(console, name)["summary"]
    assert isinstance(summary, dict)
    return int(summary["revision"])


def post(console: Console, route: str, body: object, **headers: str) -> httpx.Response:
    data = body if isinstance(body, (bytes, str)) else json.dumps(body)
    return httpx.post(console.url + "api/" + route, content=data, headers={**JSON, **headers}, timeout=10)


def error(r: httpx.Response) -> tuple[int, str]:
    return r.status_code, r.json()["error"]["code"]


# -- reads --------------------------------------------------------------------------------------


def test_nodes_lists_both_with_counts_and_pages(console: Console) -> None:
    body = httpx.get(console.url + "api/nodes", timeout=5).json()
    assert [n["node"] for n in body["nodes"]] == ["arm", "base"] and body["total"] == 2
    arm = body["nodes"][0]
    assert arm["online"] is True and arm["parameters"] == 9 and arm["pid"] > 0 and arm["revision"] >= 1
    second = httpx.get(console.url + "api/nodes", params={"offset": 1, "limit": 1}, timeout=5).json()
    assert [n["node"] for n in second["nodes"]] == ["base"] and second["total"] == 2
    by_param = httpx.get(console.url + "api/nodes", params={"q": "SPEED"}, timeout=5).json()
    assert by_param["total"] == 2  # every node has a parameter named speed
    none = httpx.get(console.url + "api/nodes", params={"q": "no-such-thing"}, timeout=5).json()
    assert none == {"total": 0, "offset": 0, "nodes": []}


def test_node_rows_carry_descriptors(console: Console) -> None:
    rows = {r["name"]: r for r in node(console, "arm")["rows"]}  # type: ignore[union-attr]
    assert rows["speed"]["type"] == "double"
    assert rows["speed"]["descriptor"]["floating_point_range"] == {
        "from_value": 0.0,
        "to_value": 5.0,
        "step": 0.0,
    }
    assert rows["serial"]["descriptor"]["read_only"] is True
    assert rows["key"] == {**rows["key"], "type": "byte_array", "value": [1, 2, 171]}
    assert rows["mode"]["descriptor"]["validators"] == [
        {"kind": "one_of", "args": [["auto", "manual", "off"]]}
    ]


def test_node_rows_carry_the_choices_their_editor_offers(console: Console) -> None:
    rows = {r["name"]: r for r in node(console, "arm")["rows"]}  # type: ignore[union-attr]
    assert rows["mode"]["choices"] == ["auto", "manual", "off"]  # its one_of validator
    assert rows["speed"]["choices"] is None and rows["tags"]["choices"] is None


@pytest.mark.parametrize(
    ("query", "status", "code"),
    [
        ({"node": "nobody"}, 404, "NOT_FOUND"),
        ({"node": "bad node!"}, 422, "INVALID_NAME"),
        ({}, 400, "BAD_REQUEST"),
    ],
)
def test_node_errors(console: Console, query: dict[str, str], status: int, code: str) -> None:
    assert error(httpx.get(console.url + "api/node", params=query, timeout=5)) == (status, code)


def test_bad_paging_is_400(console: Console) -> None:
    for query in ({"offset": "x"}, {"limit": "0"}, {"limit": "100000"}, {"offset": "-1"}):
        assert error(httpx.get(console.url + "api/nodes", params=query, timeout=5)) == (400, "BAD_REQUEST")


def test_dump_is_a_parameter_file_that_loads_back(console: Console) -> None:
    r = httpx.get(console.url + "api/dump", params={"node": "base"}, timeout=5)
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/yaml")
    assert 'filename="base.yaml"' in r.headers["content-disposition"]
    assert "ros__parameters" in r.text and "floating_point_range" in r.text
    loaded = post(console, "load", {"node": "base", "text": r.text})
    # the node's own dump: every value is the one held, so nothing is a change (its read-only
    # serial included); a changed read-only value is refused by the node
    assert loaded.status_code == 200, loaded.text
    results = {x["name"]: x for x in loaded.json()["results"]}
    assert len(results) == 9 and all(x["successful"] for x in results.values())
    assert 'SN-0042' in r.text
    changed = post(console, "load", {"node": "base", "text": r.text.replace("SN-0042", "SN-0043")})
    assert changed.status_code == 403, changed.text
    results = {x["name"]: x for x in changed.json()["results"]}
    assert len(results) == 9 and results["serial"]["code"] == "READ_ONLY"
    assert all(x["successful"] for n, x in results.items() if n != "serial")


# -- writes: success and the error table -----------------------------------------------------------


def test_set_widens_an_integer_for_a_double_and_bumps_the_revision(domain: int, console: Console) -> None:
    before = revision(console, "arm")
    r = post(console, "set", {"node": "arm", "values": {"speed": 2}})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["results"] == [{"name": "speed", "successful": True, "reason": "", "code": None}]
    assert body["revision"] > before
    assert run_cli_value(domain, "arm", "speed") == "2.0"


def run_cli_value(domain: int, node_name: str, param: str) -> str:
    out = run_cli(domain, "get", "-o", "json", node_name, param)
    assert out.returncode == 0, out.stderr
    return json.dumps(json.loads(out.stdout)[param])


def test_out_of_range_is_422_with_the_nodes_reason_and_changes_nothing(domain: int, console: Console) -> None:
    before = revision(console, "arm")
    r = post(console, "set", {"node": "arm", "values": {"speed": 9.5}})
    assert error(r) == (422, "OUT_OF_RANGE")
    # the node words it the same way when asked directly
    direct = run_cli(domain, "set", "arm", "speed=9.5")
    assert direct.returncode == 1
    assert r.json()["error"]["message"] in direct.stderr
    assert revision(console, "arm") == before


@pytest.mark.parametrize(
    ("values", "code"),
    [
        ({"speed": "fast"}, "TYPE_MISMATCH"),
        ({"speed": True}, "TYPE_MISMATCH"),
        ({"gain": 1.5}, "TYPE_MISMATCH"),
        ({"gain": 2**70}, "INVALID_VALUE"),
        ({"gain": 11}, "OUT_OF_RANGE"),
        ({"mode": "turbo"}, "INVALID_VALUE"),
        ({"limits": [1.0, "x"]}, "TYPE_MISMATCH"),
        ({"limits": [1.0, 11.0]}, "OUT_OF_RANGE"),
        ({"tags": ["a", "a"]}, "INVALID_VALUE"),
        ({"key": "abc"}, "TYPE_MISMATCH"),
        ({"key": [1, 256]}, "TYPE_MISMATCH"),
        ({"speed": None}, "INVALID_VALUE"),
        ({"speed": {"nested": 1}}, "TYPE_MISMATCH"),
        ({"bad name!": 1}, "INVALID_NAME"),
    ],
)
def test_bad_values_are_422_and_never_sent(console: Console, values: dict[str, object], code: str) -> None:
    before = revision(console, "base")
    assert error(post(console, "set", {"node": "base", "values": values})) == (422, code)
    assert revision(console, "base") == before


REFUSALS = [
    pytest.param({"speed": 9.5}, "OUT_OF_RANGE", 422, id="out-of-range"),
    pytest.param({"speed": "fast"}, "TYPE_MISMATCH", 422, id="wrong-type"),
    pytest.param({"serial": "x"}, "READ_ONLY", 403, id="read-only"),
    pytest.param({"nothing.here": 1}, "NOT_FOUND", 404, id="unknown-parameter"),
]


@pytest.mark.parametrize("atomic", [False, True], ids=["plain", "atomic"])
@pytest.mark.parametrize(("values", "code", "status"), REFUSALS)
def test_every_refused_set_answers_each_parameters_result_as_the_node_does(
    domain: int, console: Console, values: dict[str, object], code: str, status: int, atomic: bool
) -> None:
    """The console's own refusal (before sending) and the node's have one shape: the error,
    and ``results`` with one row per parameter, the reason and code the node gives."""
    before = revision(console, "arm")
    body = {"node": "arm", "values": {"gain": 3, **values}, "atomic": atomic}
    r = post(console, "set", body)
    assert error(r) == (status, code), r.text
    got = r.json()
    [(name, raw)] = values.items()
    cli = ["--atomic"] if atomic else []
    direct = run_cli(domain, "set", "-o", "json", *cli, "arm", "gain=3", f"{name}={json.dumps(raw)}")
    assert direct.returncode == 1
    node_said = json.loads(direct.stdout)
    assert [(x["name"], x["successful"]) for x in got["results"]] == [
        (n, node_said[n]["successful"]) for n in ("gain", name)
    ]
    assert [x["code"] for x in got["results"]] == [None if not atomic else "INVALID_VALUE", code]
    assert got["node"] == "arm" and got["revision"] >= before
    if code != "TYPE_MISMATCH":  # the console words a JSON value's kind, the CLI its text's
        assert [x["reason"] for x in got["results"]] == [node_said[n]["reason"] for n in ("gain", name)]
        assert got["error"]["message"] in direct.stderr  # the CLI's words for the same refusal
    if atomic:
        assert revision(console, "arm") == before


def test_good_values_of_every_editor_type_are_accepted(console: Console) -> None:
    values = {"key": "0a ff", "limits": [1, 2.5], "tags": ["x", "y"], "mode": "off", "enabled": False}
    r = post(console, "set", {"node": "base", "values": values, "atomic": True})
    assert r.status_code == 200, r.text
    assert _eventually(console, "base", "key", [10, 255])


def _eventually(console: Console, node_name: str, param: str, expected: object) -> bool:
    import time

    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        if value_of(console, node_name, param) == expected:
            return True
        time.sleep(0.05)
    return False


def test_node_refusals_map_by_code(console: Console) -> None:
    # READ_ONLY: decided by the node (the console does not pre-empt it)
    assert error(post(console, "set", {"node": "arm", "values": {"serial": "x"}})) == (403, "READ_ONLY")
    # NOT_FOUND: an undeclared parameter on a node that does not allow them
    assert error(post(console, "set", {"node": "arm", "values": {"nothing.here": 1}})) == (404, "NOT_FOUND")
    assert error(post(console, "set", {"node": "ghost", "values": {"speed": 1.0}})) == (404, "NOT_FOUND")
    assert error(post(console, "delete", {"node": "arm", "names": ["nothing.here"]})) == (404, "NOT_FOUND")


def test_compare_and_set_conflict_is_409_with_the_newer_values(console: Console) -> None:
    current = revision(console, "arm")
    ok = post(console, "set", {"node": "arm", "values": {"gain": 5}, "atomic": True, "if_revision": current})
    assert ok.status_code == 200, ok.text  # positive control: the right revision applies
    stale = post(
        console,
        "set",
        {"node": "arm", "values": {"gain": 6, "speed": 0.5}, "atomic": True, "if_revision": current},
    )
    assert error(stale) == (409, "CONFLICT")
    body = stale.json()
    assert {r["name"]: r["value"] for r in body["rows"]}["gain"] == 5
    assert body["summary"]["revision"] >= ok.json()["revision"]
    assert value_of(console, "arm", "gain") == 5


@pytest.mark.parametrize(
    ("body", "headers", "status", "code"),
    [
        (b"{not json", {}, 400, "BAD_REQUEST"),
        (b"[1, 2]", {}, 400, "BAD_REQUEST"),
        ({"node": "arm"}, {}, 400, "BAD_REQUEST"),
        ({"node": "arm", "values": {}}, {}, 400, "BAD_REQUEST"),
        ({"node": 7, "values": {"gain": 1}}, {}, 400, "BAD_REQUEST"),
        ({"node": "arm", "values": {"gain": 1}, "atomic": "yes"}, {}, 400, "BAD_REQUEST"),
        ({"node": "arm", "values": {"gain": 1}, "if_revision": -1}, {}, 400, "BAD_REQUEST"),
        ({"node": "arm", "values": {"gain": 1}}, {"Content-Type": "text/plain"}, 415, "UNSUPPORTED_MEDIA"),
        ({"node": "arm", "values": {"gain": 1}}, {"Origin": "http://evil.example"}, 403, "CROSS_ORIGIN"),
        ({"node": "arm", "values": {"gain": 1}}, {"Sec-Fetch-Site": "cross-site"}, 403, "CROSS_ORIGIN"),
        ({"node": "arm", "values": {"gain": 1}}, {"Host": "evil.example:80"}, 403, "CROSS_ORIGIN"),
        (b"[" * 100000 + b"]" * 100000, {}, 400, "BAD_REQUEST"),  # nesting deeper than the parser goes
        (b" " * (1024 * 1024 + 1), {}, 413, "TOO_LARGE"),
    ],
)
def test_bad_requests_are_4xx_and_change_nothing(
    console: Console, body: object, headers: dict[str, str], status: int, code: str
) -> None:
    before = revision(console, "arm")
    r = post(console, "set", body, **headers)
    assert error(r) == (status, code), r.text
    assert "Traceback" not in r.text
    assert revision(console, "arm") == before


def test_same_origin_write_is_allowed(console: Console) -> None:
    origin = console.url.rstrip("/")
    r = post(
        console,
        "set",
        {"node": "arm", "values": {"gain": 3}},
        Origin=origin,
        **{"Sec-Fetch-Site": "same-origin"},
    )
    assert r.status_code == 200, r.text


def test_a_huge_chunked_body_is_cut_off(console: Console) -> None:
    def chunks() -> Iterator[bytes]:
        yield b'{"node": "arm", "values": {"serial": "'
        for _ in range(2048):
            yield b"x" * 1024
        yield b'"}}'

    r = httpx.post(console.url + "api/set", content=chunks(), headers=JSON, timeout=10)
    assert error(r) == (413, "TOO_LARGE")


def test_load_reports_each_parameter_and_file_errors_with_the_line(console: Console) -> None:
    good = "base:\n  ros__parameters:\n    gain: 7\n    speed: 11.0\n"
    r = post(console, "load", {"node": "base", "text": good})
    results = {x["name"]: x for x in r.json()["results"]}
    assert (
        r.status_code == 422 and results["gain"]["successful"] and results["speed"]["code"] == "OUT_OF_RANGE"
    )
    assert _eventually(console, "base", "gain", 7)
    broken = post(console, "load", {"node": "base", "text": "base:\n  ros__parameters:\n    gain: [1,\n"})
    assert error(broken) == (422, "FILE_FORMAT") and "upload:" in broken.json()["error"]["message"]
    atomic = post(console, "load", {"node": "base", "text": good.replace("7", "8"), "atomic": True})
    assert atomic.status_code == 422 and value_of(console, "base", "gain") == 7


def test_delete_removes_a_parameter(console: Console) -> None:
    static = post(console, "delete", {"node": "base", "names": ["tags"]})
    assert error(static) == (422, "TYPE_MISMATCH")  # a statically typed parameter stays
    r = post(console, "delete", {"node": "base", "names": ["note"]})
    assert r.status_code == 200, r.text
    assert _gone(console, "base", "note")


def test_a_refused_delete_answers_each_names_result(console: Console) -> None:
    before = revision(console, "arm")
    r = post(console, "delete", {"node": "arm", "names": ["bad name!", "nothing.here"]})
    assert error(r) == (422, "INVALID_NAME"), r.text
    assert [(x["name"], x["successful"], x["code"]) for x in r.json()["results"]] == [
        ("bad name!", False, "INVALID_NAME"),
        ("nothing.here", False, "NOT_FOUND"),  # asked of the node, which has no such parameter
    ]
    assert revision(console, "arm") == before


def _gone(console: Console, node_name: str, param: str) -> bool:
    import time

    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        rows = node(console, node_name)["rows"]
        if all(r["name"] != param for r in rows):  # type: ignore[union-attr]
            return True
        time.sleep(0.05)
    return False


def test_event_stream_sends_the_node_then_its_changes(console: Console) -> None:
    with httpx.stream("GET", console.url + "api/events", params={"node": "arm"}, timeout=10) as r:
        assert r.headers["content-type"].startswith("text/event-stream")
        lines = r.iter_lines()
        first = _next_event(lines)
        assert first[0] == "node" and first[1]["node"] == "arm" and len(first[1]["rows"]) == 9
        assert post(console, "set", {"node": "arm", "values": {"gain": 9}}).status_code == 200
        while True:
            kind, data = _next_event(lines)
            if kind == "params":
                assert [row["value"] for row in data["rows"] if row["name"] == "gain"] == [9]
                break


def _next_event(lines: Iterator[str]) -> tuple[str, dict[str, object]]:
    kind = ""
    for line in lines:
        if line.startswith("event: "):
            kind = line[7:]
        elif line.startswith("data: ") and kind:
            data: dict[str, object] = json.loads(line[6:])
            return kind, data
    raise AssertionError("the stream ended")


# -- consoles with other options -------------------------------------------------------------------


def test_read_only_console_serves_no_write_route(domain: int, console: Console) -> None:
    ro = Console(domain, "--read-only")
    try:
        wait_for_nodes(ro.url, {"arm"})
        assert httpx.get(ro.url + "api/info", timeout=5).json()["read_only"] is True
        r = httpx.post(ro.url + "api/set", json={"node": "arm", "values": {"gain": 1}}, timeout=5)
        assert error(r) == (404, "NOT_FOUND")
        assert error(httpx.post(ro.url + "api/load", json={}, timeout=5))[0] == 404
    finally:
        ro.stop()


def test_token_console_needs_the_bearer_token(domain: int, console: Console, tmp_path: Path) -> None:
    token = "s3cret-token-of-some-length"
    guarded = Console(domain, "--token-file", str(write_token(tmp_path, token)))
    try:
        wait_for_nodes(guarded.url, {"arm"})
        body = {"node": "arm", "values": {"gain": 2}}
        assert error(post(guarded, "set", body)) == (401, "UNAUTHORIZED")
        assert error(post(guarded, "set", body, Authorization="Bearer wrong")) == (401, "UNAUTHORIZED")
        assert post(guarded, "set", body, Authorization=f"Bearer {token}").status_code == 200
        assert httpx.get(guarded.url + "api/nodes", timeout=5).status_code == 200  # reads need no token
    finally:
        guarded.stop()


def test_non_loopback_bind_without_token_is_refused(domain: int) -> None:
    r = run_cli(domain, "web", "--bind", "0.0.0.0:0")
    assert r.returncode == 2 and "--token-file" in r.stderr
    r = run_cli(domain, "web", "--bind", "nonsense")
    assert r.returncode == 2 and "HOST:PORT" in r.stderr


def test_offline_node_is_503_unavailable(domain: int, console: Console) -> None:
    from ._support import CONSOLE_PARAMS

    extra = start_server(domain, "-n", "brief", "-p", str(CONSOLE_PARAMS))
    wait_for_nodes(console.url, {"brief"})
    assert post(console, "set", {"node": "brief", "values": {"gain": 1}}).status_code == 200
    extra.stop()
    import time

    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and node(console, "brief")["summary"]["online"]:  # type: ignore[index]
        time.sleep(0.05)
    assert error(post(console, "set", {"node": "brief", "values": {"gain": 2}})) == (503, "UNAVAILABLE")


def test_sigterm_ends_open_streams_and_exits_0(domain: int, console: Console) -> None:
    extra = Console(domain)
    with httpx.stream("GET", extra.url + "api/events", params={"node": "arm"}, timeout=10) as r:
        lines = r.iter_lines()
        assert _next_event(lines)[0] == "node"
        extra.proc.popen.send_signal(signal.SIGTERM)
        for _ in lines:  # the server ends the stream instead of waiting for the browser
            pass
    extra.proc.popen.wait(10)
    assert extra.proc.stop() == 0  # already gone: stop() only collects the code and closes the pipes


def test_a_busy_port_is_a_usage_error(domain: int, console: Console) -> None:
    port = console.url.rstrip("/").rsplit(":", 1)[1]
    r = run_cli(domain, "web", "--bind", f"127.0.0.1:{port}")
    assert r.returncode == 2 and "cannot listen" in r.stderr


def test_openapi_schema_lists_the_routes(console: Console) -> None:
    schema = httpx.get(console.url + "api/openapi.json", timeout=5).json()
    assert schema["openapi"].startswith("3.")
    paths = schema["paths"]
    assert {
        "/api/nodes",
        "/api/node",
        "/api/dump",
        "/api/events",
        "/api/set",
        "/api/delete",
        "/api/load",
    } <= set(paths)
    assert "409" in paths["/api/set"]["post"]["responses"] and "get" in paths["/api/nodes"]
