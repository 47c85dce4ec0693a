"""``paramdds describe`` shows each parameter's last change: who, whether verified, via, when, revision."""

from __future__ import annotations

import json
from pathlib import Path

from paramdds.cli._output import describe_table, last_change_text
from paramdds.core.results import LastChange

from ..dds.helpers import DdsSession
from ._support import Proc, run_cli

_ALICE = LastChange("alice@robot-host", False, "cli", 1_764_378_123_456_789_000, 7)


def test_the_last_change_reads_as_a_sentence_and_a_claim_says_so() -> None:
    assert last_change_text(_ALICE.to_json()) == (
        "alice@robot-host (claimed) via cli at 2025-11-29T01:02:03.456789Z, revision 7"
    )
    verified = LastChange("CN=alice,O=acme", True, "web", 1_764_378_123_000_000_000, 8).to_json()
    assert last_change_text(verified) == "CN=alice,O=acme via web at 2025-11-29T01:02:03.000000Z, revision 8"


def test_the_table_shows_it_under_the_descriptor_and_nothing_when_unknown() -> None:
    described = {"type": "double", "read_only": False, "description": "top speed"}
    table = describe_table(
        {"speed": {**described, "last_change": _ALICE.to_json()}, "b": {**described, "last_change": None}}
    )
    assert table.splitlines() == [
        "speed:",
        '  type: "double"',
        "  read_only: false",
        '  description: "top speed"',
        "  last change: alice@robot-host (claimed) via cli at 2025-11-29T01:02:03.456789Z, revision 7",
        "b:",
        '  type: "double"',
        "  read_only: false",
        '  description: "top speed"',
    ]


def test_a_late_joining_describe_shows_the_last_author(
    server_factory: list[Proc], params_file: Path, domain: int
) -> None:
    """A server process, a set through a client claiming "alice", then ``paramdds describe``
    (a process of its own, which joins after the change) shows alice, claimed, via api."""
    server = Proc(domain, ["server", "-n", "robot1", "-p", str(params_file)])
    server_factory.append(server)
    server.wait_for("Serving node robot1")
    with DdsSession(domain) as dds:
        client = dds.client(as_="alice")
        reply = client.set("robot1", {"robot.max_velocity": 2.5})
        assert reply.results[0].successful
    out = run_cli(domain, "describe", "robot1", "robot.max_velocity", "robot.name", "-o", "json")
    assert out.returncode == 0, out.stderr
    described = json.loads(out.stdout)
    last = described["robot.max_velocity"]["last_change"]
    assert {k: last[k] for k in ("who", "verified", "via", "revision")} == {
        "who": "alice",
        "verified": False,  # a claim: no DDS Security here
        "via": "api",
        "revision": reply.revision,
    }
    assert last["time"].endswith("Z")
    assert described["robot.name"]["last_change"]["via"] == "start"  # never changed since
    table = run_cli(domain, "describe", "robot1", "robot.max_velocity")
    assert table.returncode == 0, table.stderr
    shown = f"  last change: alice (claimed) via api at {last['time']}, revision {reply.revision}"
    assert shown in table.stdout.splitlines()
