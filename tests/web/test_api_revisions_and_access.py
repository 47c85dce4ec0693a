"""The API on revisions and access, against a real console, real servers and real Cyclone
on loopback: compare-and-set across a restart, writes to an offline node, loading a node's
own dump, malformed requests and revisions, the Host check and the token off loopback, a
node hosted twice."""

from __future__ import annotations

import json
import signal
import socket
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from ..cli._support import Proc, run_cli, start_server
from ._support import CONSOLE_PARAMS, Console, write_token
from .conftest import wait_for_nodes
from .test_api import error, node, post


def summary(console: Console, name: str) -> dict[str, Any]:
    s = node(console, name)["summary"]
    assert isinstance(s, dict)
    return s


def wait_summary(console: Console, name: str, predicate: Any, timeout: float = 10.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    s = summary(console, name)
    while not predicate(s):
        assert time.monotonic() < deadline, f"{name}: {s}"
        time.sleep(0.05)
        s = summary(console, name)
    return s


def kill(proc: Proc) -> None:
    proc.popen.send_signal(signal.SIGKILL)
    proc.stop()


@pytest.mark.slow
def test_compare_and_set_follows_a_restart_and_never_matches_the_old_start(
    domain: int, console: Console
) -> None:
    """A node raised by two revisions from the console, killed and restarted (back at its
    start revision): the console shows the new start's revision, not the highest ever seen; a
    set against the old start at that revision conflicts (its reply carries the new state), one against the
    new start applies."""
    first = start_server(domain, "-n", "phoenix", "-p", str(CONSOLE_PARAMS))
    try:
        wait_for_nodes(console.url, {"phoenix"})
        start = summary(console, "phoenix")["revision"]
        for gain in (1, 2):
            assert post(console, "set", {"node": "phoenix", "values": {"gain": gain}}).status_code == 200
        old = wait_summary(console, "phoenix", lambda s: s["revision"] == start + 2)
        assert len(old["incarnation"]) == 16 and int(old["incarnation"], 16) != 0
    finally:
        kill(first)
    wait_summary(console, "phoenix", lambda s: not s["online"])
    again = start_server(domain, "-n", "phoenix", "-p", str(CONSOLE_PARAMS))
    try:
        new = wait_summary(
            console, "phoenix", lambda s: s["online"] and s["incarnation"] != old["incarnation"]
        )
        assert new["revision"] == start  # the restarted node's own revision, not the highest seen
        stale_at = f"{old['incarnation']}:{start}"
        stale = post(
            console,
            "set",
            {"node": "phoenix", "values": {"gain": 5}, "atomic": True, "if_revision": stale_at},
        )
        assert error(stale) == (409, "CONFLICT")  # the revision matches, the start does not
        body = stale.json()
        assert (body["summary"]["incarnation"], body["summary"]["revision"]) == (new["incarnation"], start)
        assert (body["incarnation"], body["revision"]) == (new["incarnation"], start)
        fresh = f"{new['incarnation']}:{new['revision']}"
        ok = post(
            console, "set", {"node": "phoenix", "values": {"gain": 5}, "atomic": True, "if_revision": fresh}
        )
        assert ok.status_code == 200 and ok.json()["revision"] == start + 1, ok.text
    finally:
        again.stop()


def test_a_write_to_a_node_the_console_sees_offline_is_503_at_once(domain: int, console: Console) -> None:
    """Item 3: after a kill the console knows the node is offline and says so at once,
    instead of a 504 after the client's 5 s timeout."""
    doomed = start_server(domain, "-n", "gone", "-p", str(CONSOLE_PARAMS))
    wait_for_nodes(console.url, {"gone"})
    assert post(console, "set", {"node": "gone", "values": {"gain": 1}}).status_code == 200  # control
    kill(doomed)
    wait_summary(console, "gone", lambda s: not s["online"])
    for body in (
        {"node": "gone", "values": {"gain": 2}},
        {"node": "gone", "values": {"gain": 2}, "atomic": True},
    ):
        started = time.monotonic()
        r = post(console, "set", body)
        assert error(r) == (503, "UNAVAILABLE") and "offline" in r.json()["error"]["message"]
        assert time.monotonic() - started < 1.0
    started = time.monotonic()
    assert error(post(console, "delete", {"node": "gone", "names": ["note"]})) == (503, "UNAVAILABLE")
    assert time.monotonic() - started < 1.0


def test_loading_a_nodes_own_dump_changes_nothing(console: Console) -> None:
    """Item 10: its read-only parameters are unchanged, so not refused; nothing is sent."""
    before = summary(console, "base")
    text = httpx.get(console.url + "api/dump", params={"node": "base"}, timeout=5).text
    assert "serial" in text  # the read-only parameter is in the dump
    r = post(console, "load", {"node": "base", "text": text})
    assert r.status_code == 200, r.text
    results = {x["name"]: x for x in r.json()["results"]}
    assert results["serial"]["successful"] and results["serial"]["reason"] == "unchanged"
    assert all(x["successful"] for x in results.values()) and len(results) == 9
    assert summary(console, "base")["revision"] == before["revision"]  # not a change
    # a changed value in the same file is still sent, beside the unchanged read-only one
    changed = text.replace("gain: 4", "gain: 6") if "gain: 4" in text else None
    assert changed is not None and changed != text
    r = post(console, "load", {"node": "base", "text": changed})
    assert r.status_code == 200 and r.json()["revision"] == before["revision"] + 1, r.text
    assert post(console, "set", {"node": "base", "values": {"gain": 4}}).status_code == 200  # as it was


def _raw(console: Console, request: bytes) -> tuple[int, dict[str, str], bytes]:
    host, port = console.url.removeprefix("http://").rstrip("/").rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as s:
        s.sendall(request)
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    headers = {k.lower(): v.strip() for k, _, v in (line.partition(":") for line in lines[1:])}
    return int(lines[0].split()[1]), headers, body


def test_a_request_without_host_gets_the_json_error_body(console: Console) -> None:
    """Item 13: not uvicorn's plain text; the same JSON error shape and headers as every error."""
    import json

    status, headers, body = _raw(console, b"GET /api/nodes HTTP/1.1\r\nConnection: close\r\n\r\n")
    assert status == 400 and headers["content-type"] == "application/json"
    assert json.loads(body)["error"]["code"] == "BAD_REQUEST"
    assert "default-src 'self'" in headers["content-security-policy"]
    status, _, body = _raw(console, b"GET /api/nodes HTTP/1.0\r\n\r\n")  # HTTP/1.0 may omit Host
    assert status == 403 and json.loads(body)["error"]["code"] == "CROSS_ORIGIN"
    status, _, _ = _raw(console, b"GET /api/nodes HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
    assert status == 200  # control


@pytest.mark.parametrize("bad", [2**64, 2**63, -1, "12", "zz:3", "0000000000000001:x", True, 1.5])
def test_an_if_revision_out_of_range_is_a_400(console: Console, bad: object) -> None:
    """Item 13: 2**64 was a 422 "could not send the request"."""
    before = summary(console, "arm")["revision"]
    r = post(console, "set", {"node": "arm", "values": {"gain": 4}, "if_revision": bad})
    if bad == "12":  # a bare revision as a string is a revision too: a CONFLICT, not a 400
        assert r.status_code in (200, 409)
        return
    assert error(r) == (400, "BAD_REQUEST") and "if_revision" in r.json()["error"]["message"]
    assert summary(console, "arm")["revision"] == before


def test_favicon_is_served(console: Console) -> None:
    """Item 11: was a 404 on every page load."""
    r = httpx.get(console.url + "favicon.ico", timeout=5)
    assert r.status_code == 200 and r.headers["content-type"].startswith("image/svg+xml")
    assert b"<svg" in r.content


@pytest.mark.slow
def test_a_console_reachable_from_other_machines_checks_host_and_needs_the_token_to_read(
    domain: int, servers: Proc, tmp_path: Path
) -> None:
    """Security: on a non-loopback bind a DNS-rebinding page (Host: evil.example) reads
    nothing, and reads need the token (header, or the cookie the page sets), also read-only."""
    token = "s3cret-token-for-reads-0123"
    path = write_token(tmp_path, token)
    refused = run_cli(domain, "web", "--bind", "0.0.0.0:0", "--read-only")
    assert refused.returncode == 2 and "--token-file" in refused.stderr  # reads need it there too
    remote = Console(domain, "--bind", "0.0.0.0:0", "--read-only", "--token-file", str(path))
    try:
        url = remote.url.replace("0.0.0.0", "127.0.0.1")
        wait = time.monotonic() + 15
        bearer = {"Authorization": f"Bearer {token}"}
        while time.monotonic() < wait:  # until the console holds both nodes
            r = httpx.get(url + "api/nodes", headers=bearer, timeout=5)
            if r.status_code == 200 and r.json()["total"] >= 2:
                break
            time.sleep(0.1)
        for path_ in ("", "api/nodes", "api/node?node=arm", "api/dump?node=arm", "api/info"):
            evil = httpx.get(url + path_, headers={"Host": "evil.example", **bearer}, timeout=5)
            assert error(evil) == (403, "CROSS_ORIGIN"), path_
        for path_ in ("api/nodes", "api/node?node=arm", "api/dump?node=arm"):
            assert error(httpx.get(url + path_, timeout=5)) == (401, "UNAUTHORIZED"), path_
            wrong = {"Authorization": "Bearer not-the-token-at-all"}
            assert error(httpx.get(url + path_, headers=wrong, timeout=5)) == (401, "UNAUTHORIZED")
            assert httpx.get(url + path_, headers=bearer, timeout=5).status_code == 200, path_
            cookie = {"Cookie": f"paramdds-token={token}"}
            assert httpx.get(url + path_, headers=cookie, timeout=5).status_code == 200, path_
        assert error(httpx.get(url + "api/events?node=arm", timeout=5)) == (401, "UNAUTHORIZED")
        ask = json.dumps({"node": "arm", "values": {"gain": 11}})
        json_body = {"Content-Type": "application/json"}
        unasked = httpx.post(url + "api/validate", content=ask, headers=json_body, timeout=5)
        assert error(unasked) == (401, "UNAUTHORIZED")
        checked = httpx.post(url + "api/validate", content=ask, headers={**json_body, **bearer}, timeout=5)
        assert checked.json()["results"][0]["code"] == "OUT_OF_RANGE"  # a read: there with --read-only
        info = httpx.get(url + "api/info", timeout=5).json()  # what the page needs to ask for it
        assert info["token_for_reads"] is True and info["token_required"] is True
        assert httpx.get(url, timeout=5).status_code == 200  # the page itself holds no data
    finally:
        remote.stop()


@pytest.mark.slow
def test_when_one_of_two_hosts_of_a_node_stops_the_summary_shows_the_other(
    domain: int, console: Console
) -> None:
    """Item 11: the summary kept the dead pid (and `nodes` kept it as a second host)."""
    first = start_server(domain, "-n", "twin", "-p", str(CONSOLE_PARAMS))
    second: Proc | None = None
    try:
        wait_for_nodes(console.url, {"twin"})
        start = summary(console, "twin")["revision"]
        second = start_server(domain, "-n", "twin", "-p", str(CONSOLE_PARAMS))
        procs = {first.popen.pid: first, second.popen.pid: second}
        assert run_cli(domain, "set", "twin", "gain=5").returncode == 0  # both apply it and write presence
        shown = wait_summary(console, "twin", lambda s: s["pid"] in procs and s["revision"] == start + 1)
        doomed = procs.pop(shown["pid"])  # the one shown, whichever wrote last
        (kept,) = procs
        kill(doomed)
        survivor = wait_summary(console, "twin", lambda s: s["pid"] != doomed.popen.pid)
        assert survivor["pid"] == kept and survivor["online"]
        (row,) = [r for r in json.loads(run_cli(domain, "nodes", "-o", "json").stdout) if r["node"] == "twin"]
        assert (row["pid"], row["also_hosted_by"]) == (kept, [])
    finally:
        first.stop()
        if second is not None and second.popen.poll() is None:
            second.stop()
