"""Who changed what through the console, and a node's past: real console, real servers, real Cyclone.

A write made through the console is recorded by its node as the operator's (the name the
page gives, or the name its token carries), ``via web``, unverified; ``/api/history``
lists it, newest first, beside the writes the node refused.
"""

from __future__ import annotations

from pathlib import Path

import httpx
import pytest

from paramdds.core.origin import local_identity

from ..cli._support import next_domain, start_server
from ..dds.helpers import DdsSession
from ._support import CONSOLE_PARAMS, Console
from .conftest import wait_for_nodes
from .test_api import error, post


def history(console: Console, **params: object) -> httpx.Response:
    return httpx.get(console.url + "api/history", params=params, timeout=10)  # type: ignore[arg-type]


def test_a_set_is_made_as_the_operator_and_is_in_its_history(console: Console) -> None:
    post(console, "set", {"node": "arm", "values": {"gain": 3}}).raise_for_status()
    r = post(console, "set", {"node": "arm", "values": {"gain": 6}, "as": "carol"})
    assert r.status_code == 200, r.text
    done = r.json()
    assert done["who"] == "carol"

    body = history(console, node="arm", name="gain").json()
    assert body["kept"] is True and body["compacted"] is False and body["names"] == ["gain"]
    newest = body["records"][0]
    assert newest["revision"] == done["revision"] and newest["outcome"] == "applied"
    assert (newest["who"], newest["via"], newest["verified"]) == ("carol", "web", False)
    assert (newest["old"], newest["new"]) == (3, 6) and newest["old_type"] == newest["new_type"] == "integer"
    revisions = [rec["revision"] for rec in body["records"]]
    assert revisions == sorted(revisions, reverse=True)  # newest first
    assert {rec["name"] for rec in body["records"]} == {"gain"}


def test_a_set_without_a_name_is_made_as_the_console(console: Console) -> None:
    r = post(console, "set", {"node": "arm", "values": {"gain": 2}})
    assert r.status_code == 200, r.text
    assert r.json()["who"] == local_identity()  # the console's process runs as this test's user, here
    records = history(console, node="arm", name="gain", limit=1).json()["records"]
    assert records[0]["who"] == local_identity() and records[0]["via"] == "web"


def test_a_refused_write_is_in_the_history_with_its_reason(console: Console) -> None:
    r = post(console, "set", {"node": "arm", "values": {"serial": "SN-9"}, "as": "carol"})
    assert r.status_code == 403 and r.json()["error"]["code"] == "READ_ONLY"
    body = history(console, node="arm", name="serial", outcome="refused").json()
    refused = body["records"][0]
    assert refused["outcome"] == "refused" and refused["who"] == "carol"
    assert refused["old"] == "SN-0042" and refused["new"] == "SN-9" and refused["code"] == "READ_ONLY"
    assert "read-only" in refused["reason"].lower() or "read only" in refused["reason"].lower()
    applied = history(console, node="arm", name="serial", outcome="applied").json()["records"]
    assert all(rec["outcome"] == "applied" for rec in applied)


def test_history_filters_since_a_revision_and_by_who(console: Console) -> None:
    first = post(console, "set", {"node": "base", "values": {"speed": 2.0}, "as": "dave"}).json()
    second = post(console, "set", {"node": "base", "values": {"speed": 3.0}, "as": "erin"}).json()
    since = history(console, node="base", since=str(first["revision"])).json()["records"]
    assert [(rec["revision"], rec["who"]) for rec in since] == [(second["revision"], "erin")]
    by_dave = history(console, node="base", who="da*").json()["records"]
    assert by_dave and all(rec["who"] == "dave" for rec in by_dave)
    later = history(console, node="base", since="2200-01-01T00:00:00Z").json()
    assert later["records"] == [] and later["kept"] is True


@pytest.mark.parametrize(
    ("params", "status", "code"),
    [
        ({"node": "arm", "since": "yesterday"}, 400, "BAD_REQUEST"),
        ({"node": "arm", "until": "12:00"}, 400, "BAD_REQUEST"),
        ({"node": "arm", "since": "2999-01-01T00:00:00Z"}, 400, "BAD_REQUEST"),  # past int64 nanoseconds
        ({"node": "arm", "outcome": "some"}, 400, "BAD_REQUEST"),
        ({"node": "arm", "limit": "0"}, 400, "BAD_REQUEST"),
        ({"node": "arm", "name": "bad name!"}, 422, "INVALID_NAME"),
        ({"node": "nowhere"}, 404, "NOT_FOUND"),
        ({}, 400, "BAD_REQUEST"),
    ],
)
def test_bad_history_queries_are_refused_with_their_reason(
    console: Console, params: dict[str, str], status: int, code: str
) -> None:
    assert error(history(console, **params)) == (status, code)
    assert history(console, node="arm").status_code == 200  # the positive control


def test_a_named_token_names_the_operator_over_what_the_page_claims(
    domain: int, console: Console, tmp_path: Path
) -> None:
    """Who a write is made as: the name its token carries, else the page's, else the console's own."""
    named, unnamed = "frank-token-0123456789", "shared-token-0123456789"
    path = tmp_path / "tokens"
    path.write_text(f"# operators\nfrank {named}\n{unnamed}\n")
    guarded = Console(domain, "--token-file", str(path), "--as", "console-arm")
    try:
        wait_for_nodes(guarded.url, {"arm", "base"})
        body = {"node": "arm", "values": {"gain": 7}, "as": "mallory"}
        assert error(post(guarded, "set", body)) == (401, "UNAUTHORIZED")
        cases = [
            (named, {"as": "mallory"}, "frank"),  # the token's name wins over the page's claim
            (unnamed, {"as": "gina"}, "gina"),
            (unnamed, {}, "console-arm"),  # nobody said: the console's --as
        ]
        for gain, (token, claim, who) in enumerate(cases, 1):
            r = post(
                guarded,
                "set",
                {"node": "arm", "values": {"gain": gain}, **claim},
                Authorization=f"Bearer {token}",
            )
            assert r.status_code == 200, r.text
            assert r.json()["who"] == who
            newest = history(guarded, node="arm", name="gain", limit=1).json()["records"][0]
            assert (newest["who"], newest["verified"], newest["via"], newest["new"]) == (
                who,
                False,
                "web",
                gain,
            )
    finally:
        guarded.stop()


def test_a_range_past_retention_says_history_was_dropped(domain: int, console: Console) -> None:
    small = start_server(domain, "-n", "tiny", "-p", str(CONSOLE_PARAMS), "--history-records", "2")
    try:
        wait_for_nodes(console.url, {"tiny"})
        for gain in (1, 2, 3):
            post(console, "set", {"node": "tiny", "values": {"gain": gain}}).raise_for_status()
        body = history(console, node="tiny", name="gain").json()
        assert body["compacted"] is True and len(body["records"]) <= 2
        assert body["records"][0]["new"] == 3
    finally:
        small.stop()


def test_a_node_that_keeps_no_history_is_said_to_keep_none() -> None:
    """A peer without history (an older release, a foreign one) answers ``history_kept`` FALSE:
    the console says so, with no record, instead of an error or a hang."""
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
            body = history(console, node="old_peer", name="speed").json()
            assert body == {
                "node": "old_peer", "names": ["speed"], "kept": False, "compacted": False, "more": False,
                "records": [],
            }  # fmt: skip
        finally:
            console.stop()
