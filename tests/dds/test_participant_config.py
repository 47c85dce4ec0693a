"""``localhost=True`` refines a user's ``CYCLONEDDS_URI``, also one that selects loopback itself."""

from __future__ import annotations

from pathlib import Path

import pytest

from paramdds.dds.participant import close_participant, domain_config, make_participant

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
