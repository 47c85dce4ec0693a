"""``paramdds describe`` shows each parameter's last change: who, whether verified, via, when, revision."""

from __future__ import annotations

from paramdds.cli._output import describe_table, last_change_text
from paramdds.core.results import LastChange

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
