"""Which sites a remote view lacks: the ledger's rules (pure, no Zenoh)."""

from __future__ import annotations

from paramdds.zenoh.completeness import EVERY_SITE, SiteLedger


def test_a_named_site_without_a_gateway_is_missing_and_an_answered_one_is_not() -> None:
    ledger = SiteLedger(["north", "east"])
    ledger.gateways_up(["north", "south"])
    ledger.answered(["north", "south", "east"], 5.0)  # east: its query ended at once, no gateway
    assert set(ledger.missing()) == {"east"}
    assert "no gateway of site 'east' is reachable" in ledger.missing()["east"]
    assert set(ledger.missing(lacking=["south"])) == {"east", "south"}


def test_a_site_seen_that_did_not_answer_in_time_is_missing() -> None:
    ledger = SiteLedger()
    ledger.gateways_up(["north"])
    ledger.nodes_seen(["west"])
    ledger.answered([], 2.0)
    assert ledger.missing() == {
        "north": "site 'north' did not answer within 2 s",
        "west": "no gateway of site 'west' is reachable (site not connected, its uplink down, "
        "or this client not granted it)",
    }


def test_no_site_known_at_all_is_never_an_empty_complete_fleet() -> None:
    assert set(SiteLedger().missing()) == {EVERY_SITE}
