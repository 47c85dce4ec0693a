"""``localhost=True`` refines a user's ``CYCLONEDDS_URI``, also one that selects loopback itself."""

from __future__ import annotations

from pathlib import Path

import pytest

from paramdds.dds.participant import (
    ROS_COEXISTENCE_XML,
    close_participant,
    domain_config,
    make_participant,
    participant_config,
)

from ..conftest import TEST_URI

_LO = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="lo"/></Interfaces>'
    "</General></Domain></CycloneDDS>"
)


@pytest.mark.parametrize("form", ["inline", "file"])
def test_localhost_with_a_configuration_that_already_selects_lo(
    form: str, domain_id: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Was DDS_RETCODE_ERROR ("the same interface may not be selected twice"): exit 4."""
    uri = f"{TEST_URI},{_LO}"
    if form == "file":
        path = tmp_path / "cyclone.xml"
        path.write_text(_LO)
        uri = f"{TEST_URI},file://{path}"
    monkeypatch.setenv("CYCLONEDDS_URI", uri)
    config = domain_config(localhost=True)
    assert config is not None and config.startswith(uri)
    assert '<NetworkInterface address="127.0.0.1"/>' not in config  # ours left out, the user's kept
    assert '<Peer address="127.0.0.1"/>' in config  # the rest of ours still applies
    participant = make_participant(domain_id, localhost=True)
    close_participant(participant)


def test_localhost_keeps_its_interface_when_the_user_selects_none(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CYCLONEDDS_URI", TEST_URI)
    config = domain_config(localhost=True)
    assert config is not None and '<NetworkInterface address="127.0.0.1"/>' in config


def test_every_participant_ignores_fast_dds_type_information_unless_the_user_says_otherwise(
    domain_id: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Cyclone answering Fast DDS's type lookups left ROS 2 services unmatched (docs/ros2.md): the
    option comes first, so a user's CYCLONEDDS_URI may set it again; domain_config, which other
    programs are given (a Cyclone older than 11 refuses the option), does not carry it."""
    monkeypatch.setenv("CYCLONEDDS_URI", TEST_URI)
    assert "IgnoreTypeInformation" not in (domain_config(localhost=True) or "")
    for config in (participant_config(), participant_config(localhost=True, short_lived=True)):
        assert config.startswith(ROS_COEXISTENCE_XML + ",") and TEST_URI in config
    monkeypatch.delenv("CYCLONEDDS_URI")
    assert participant_config() == ROS_COEXISTENCE_XML
    close_participant(make_participant(domain_id, localhost=True))  # the library takes the option


def test_a_domain_the_application_made_itself_is_joined_as_it_is(domain_id: int) -> None:
    """An application's own DomainParticipant made the domain: paramdds joins it (without its
    coexistence setting, said once in the log) instead of failing to configure it."""
    from cyclonedds.domain import DomainParticipant

    from paramdds import ParameterClient, close_participant, make_participant

    own = DomainParticipant(domain_id)
    dp = make_participant(domain_id)
    try:
        with ParameterClient(dp) as client:
            assert client.nodes() == []
    finally:
        close_participant(dp)
        close_participant(own)


def test_a_domain_id_can_be_used_again_after_its_participants_closed(domain_id: int) -> None:
    """The configured Domain goes with its last participant: Cyclone refused to configure the
    domain id again in the same process (a long-lived process, or a test run that wraps its
    domain ids), while the first Domain outlived every participant."""
    from cyclonedds.domain import Domain

    from paramdds import ParameterClient, close_participant, make_participant

    for _ in range(2):
        first = make_participant(domain_id, localhost=True)
        second = make_participant(domain_id, localhost=True)
        close_participant(first)
        close_participant(first)  # twice is harmless, and releases the Domain once
        with ParameterClient(second) as client:  # the Domain is still there for the other
            assert client.nodes() == []
        close_participant(second)
    Domain(domain_id, "<CycloneDDS/>")  # nothing of ours is left on that id
