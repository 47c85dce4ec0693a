"""The bridge's ROS 2 participant runs without XTypes type lookup (real processes, one domain id).

Fast DDS 3.2 can crash (SIGSEGV) in type lookup when many endpoints of a type it does not
know are discovered at once (paramdds.ros2.rosside). The bridge's participant turns type
propagation off (``fastdds.type_propagation`` = ``disabled``): then it neither looks types up
nor announces type information. The second half is what another participant can see: a
Cyclone participant that reads Fast DDS's type information (without paramdds's
``IgnoreTypeInformation``) finds a type identifier on a plain rclpy node's endpoints and on
none of the bridge's, also when the user gives the bridge a Fast DDS profiles file of their
own (the property is added to it). The profile's editing is pure logic, tested first.
"""

from __future__ import annotations

import time
import uuid
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from paramdds.ros2.fastdds_profile import PROPERTY, with_type_lookup_off
from paramdds.ros2.rosside import TYPES_SERVICE
from tests.support.ros2_shared import _Proc, _python, shared_env

from .conftest import SHORT_LEASE, RosHost, require_ros2
from .test_shared_domain import _quiet_domain

pytestmark = [pytest.mark.timeout(120)]

HIDDEN_LOG = f"rt{TYPES_SERVICE}/log"  # the bridge's hidden Log publisher, as a DDS topic


def _default_participant(text: str) -> ET.Element:
    root = ET.fromstring(text)
    found = [p for p in root.iter(f"{NS}participant") if p.get("is_default_profile") == "true"]
    assert len(found) == 1, text
    return found[0]


def _property(participant: ET.Element) -> list[str | None]:
    return [
        p.findtext(f"{NS}value")
        for p in participant.iter(f"{NS}property")
        if p.findtext(f"{NS}name") == PROPERTY
    ]


NS = "{http://www.eprosima.com}"


def test_a_users_default_participant_profile_gains_the_property_and_keeps_its_settings() -> None:
    text, value = with_type_lookup_off(SHORT_LEASE)
    assert value == "disabled"
    participant = _default_participant(text)
    assert participant.get("profile_name") == "short_lease"
    assert _property(participant) == ["disabled"]
    assert participant.findtext(f"{NS}rtps/{NS}builtin/{NS}discovery_config/{NS}leaseDuration/{NS}sec") == "3"
    assert "ns0:" not in text and "<participant " in text  # Fast DDS matches names without a prefix


def test_profiles_without_a_default_participant_profile_gain_one() -> None:
    other = (
        '<dds xmlns="http://www.eprosima.com"><profiles>'
        '<participant profile_name="mine"><domainId>4</domainId></participant>'
        '<data_writer profile_name="/chatter"><qos/></data_writer>'
        "</profiles></dds>"
    )
    text, value = with_type_lookup_off(other)
    assert value == "disabled"
    assert _property(_default_participant(text)) == ["disabled"]
    root = ET.fromstring(text)
    names = [p.get("profile_name") for p in root.iter(f"{NS}participant")]
    assert names == ["mine", "paramdds_bridge_ros2_side"]
    assert root.find(f"{NS}profiles/{NS}data_writer") is not None


def test_a_value_the_user_sets_holds() -> None:
    mine = SHORT_LEASE.replace(
        "<rtps>",
        "<rtps><propertiesPolicy><properties><property><name>fastdds.type_propagation</name>"
        "<value>enabled</value></property></properties></propertiesPolicy>",
    )
    assert with_type_lookup_off(mine) == (mine, "enabled")


@pytest.mark.parametrize("text", ["", "<profiles", "<CycloneDDS/>"])
def test_what_is_not_a_profiles_document_is_refused(text: str) -> None:
    with pytest.raises(ValueError):
        with_type_lookup_off(text)


def _endpoints(domain: int, until: Any, timeout: float = 30.0) -> dict[uuid.UUID, list[Any]]:
    """Every endpoint a plain Cyclone participant (one that keeps Fast DDS's type information)
    discovers on ``domain``, by participant, once ``until(endpoints)`` holds."""
    from cyclonedds.builtin import (
        BuiltinDataReader,
        BuiltinTopicDcpsPublication,
        BuiltinTopicDcpsSubscription,
    )
    from cyclonedds.domain import Domain, DomainParticipant

    from paramdds.dds.participant import domain_config

    domain_obj = Domain(domain, domain_config(localhost=True))
    dp = DomainParticipant(domain)
    readers = [BuiltinDataReader(dp, t) for t in (BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription)]
    seen: dict[uuid.UUID, Any] = {}
    by_participant: dict[uuid.UUID, list[Any]] = {}
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for reader in readers:
                for sample in reader.take(N=1000):
                    if hasattr(sample, "topic_name"):
                        seen[sample.key] = sample
            by_participant = {}
            for sample in seen.values():
                by_participant.setdefault(sample.participant_key, []).append(sample)
            if until(by_participant):
                break
            time.sleep(0.2)
    finally:
        del readers, dp, domain_obj
    return by_participant


def _with_topic(by_participant: dict[uuid.UUID, list[Any]], topic: str, but: str = "") -> list[Any]:
    """The endpoints of the participant that has an endpoint on ``topic`` and none on ``but``
    (empty: none seen). The bridge, a client of every node it mirrors, has endpoints on the
    nodes' request topics too: ``but`` tells it apart."""

    def on(eps: list[Any], name: str) -> bool:
        return any(e.topic_name == name for e in eps)

    return next((eps for eps in by_participant.values() if on(eps, topic) and not on(eps, but)), [])


@pytest.mark.slow
@pytest.mark.parametrize("profiles", ["none", "the user's"])
def test_the_bridges_ros2_participant_announces_no_type_information(
    profiles: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    require_ros2()
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)  # Fast DDS knows no discovery tag
    domain, dp = _quiet_domain()
    from paramdds.dds.participant import close_participant

    close_participant(dp)  # the observer below takes this domain id with its own configuration
    env = shared_env(domain, tmp_path)
    host = RosHost(env, "--node", "/plain/node")
    bridge_env = dict(env)
    if profiles != "none":
        (tmp_path / "short_lease.xml").write_text(SHORT_LEASE)
        bridge_env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(tmp_path / "short_lease.xml")
    cmd = _python("-m", "paramdds.cli", "ros2", "--mirror", "/plain/*", "--resync", "0")
    bridge = _Proc(cmd, bridge_env, log=tmp_path / "bridge.log")
    try:

        def both(by_participant: dict[uuid.UUID, list[Any]]) -> bool:
            plain = _with_topic(by_participant, "rq/plain/node/get_parametersRequest", but=HIDDEN_LOG)
            ours = _with_topic(by_participant, HIDDEN_LOG)
            return len(plain) >= 10 and any(e.topic_name == "rt/parameter_events" for e in ours)

        by_participant = _endpoints(domain, both)
        plain = _with_topic(by_participant, "rq/plain/node/get_parametersRequest", but=HIDDEN_LOG)
        ours = _with_topic(by_participant, HIDDEN_LOG)
        assert plain and ours, (bridge.proc.poll(), bridge.tail(), sorted(by_participant))
        # the observer reads type information where Fast DDS sends it: a plain node's endpoints
        assert any(e.type_id is not None for e in plain), sorted(e.topic_name for e in plain)
        typed = sorted(e.topic_name for e in ours if e.type_id is not None)
        assert typed == [], f"{len(typed)} of {len(ours)} endpoints of the bridge announce a type: {typed}"
        assert bridge.proc.poll() is None, bridge.tail()
    finally:
        bridge.stop()
        host.close()
