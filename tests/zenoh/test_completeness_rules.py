"""Which sites a remote view lacks: the ledger's rules (pure, no Zenoh)."""

from __future__ import annotations

from paramdds.zenoh.completeness import EVERY_SITE, Lack, SiteLedger, lacking_exit


def test_a_named_site_without_a_gateway_is_missing_and_an_answered_one_is_not() -> None:
    ledger = SiteLedger(["north", "east"])
    ledger.gateways_up(["north", "south"])
    ledger.answered(["north", "south", "east"])  # east: its query ended at once, no gateway
    assert set(ledger.missing()) == {"east"}
    assert "no gateway of site 'east' is reachable" in ledger.missing()["east"].reason
    assert set(ledger.missing(lacking=["south"])) == {"east", "south"}


def test_a_site_seen_that_did_not_answer_in_time_is_missing() -> None:
    ledger = SiteLedger()
    ledger.gateways_up(["north"])
    ledger.nodes_seen(["west"])
    ledger.answered([])
    assert ledger.missing() == {
        "north": Lack("site 'north' did not answer in time (its state query did not end)"),
        "west": Lack(
            "no gateway of site 'west' is reachable (site not connected, its uplink down, "
            "or this client not granted it)"
        ),
    }
    assert lacking_exit(ledger.missing()) == 3


def test_a_site_refused_is_not_granted_and_a_refusal_alone_exits_1() -> None:
    ledger = SiteLedger()
    ledger.gateways_up(["north", "south"])
    ledger.refused(["south"])
    ledger.answered(["north"])
    missing = ledger.missing()
    assert list(missing) == ["south"] and missing["south"].refused
    assert "site 'south' is not granted to this client" in missing["south"].reason
    assert lacking_exit(missing) == 1
    assert lacking_exit({}) == 0


def test_no_site_known_at_all_is_never_an_empty_complete_fleet() -> None:
    assert set(SiteLedger().missing()) == {EVERY_SITE}


def test_a_site_whose_gateways_all_went_is_missing_until_one_is_back() -> None:
    ledger = SiteLedger(["north"])
    ledger.gateways_up(["north"])
    ledger.answered(["north"])
    assert ledger.missing() == {}
    missing = ledger.missing(down=["north"])
    assert list(missing) == ["north"] and missing["north"].status == "no answer"
    assert "no gateway of site 'north' is reachable" in missing["north"].reason
    ledger.refused(["north"])  # a refused site whose gateway went: unreachable is the first cause
    assert ledger.missing(down=["north"])["north"].status == "no answer"
    assert ledger.missing()["north"].status == "not granted"
