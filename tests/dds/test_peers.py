"""A peer whose type or QoS does not match ours is reported, loudly and once, never silently ignored.

Real Cyclone: a peer built from an older IDL runs in a subprocess (one process
holds one type per topic name); peers with other QoS are plain participants in
this process (Cyclone matches them exactly as across processes). Each
test first shows the peer's correct counterpart matching and working (the
positive control), then the mismatched one being reported with its topic,
policy, process and pid, once however often Cyclone raises the status.
"""

import logging
import subprocess
import sys

import pytest
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader

from paramdds.core.table import ParameterTable
from paramdds.dds.assign import Assigner
from paramdds.dds.client import SetReply
from paramdds.dds.participant import peer_mismatches
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.errors import CallTimeoutError

from ..conftest import make_dds_env
from .helpers import DdsSession, wait_until

pytestmark = pytest.mark.timeout(60)


# A peer built from an older IDL: the same type name, another shape (@appendable, fewer members).
_OLD_PEER = r"""
import sys
from dataclasses import dataclass
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import appendable, key
from cyclonedds.idl.types import bounded_str, uint64
from cyclonedds.pub import DataWriter
from paramdds.dds.topics import make_topic
from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.qos import QosProfiles

@dataclass
@appendable
class OldGetRequest(IdlStruct, typename="paramdds.GetParametersRequest"):
    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0

dp = make_participant(int(sys.argv[1]), localhost=True, app_name="odd-peer")
topic = make_topic(dp, "GetParametersRequest", OldGetRequest)
writer = DataWriter(dp, topic, QosProfiles.load().writer("GetParametersRequest"))
print(writer.guid, flush=True)
sys.stdin.readline()
writer.write(OldGetRequest("robot1", 1))
print("wrote", flush=True)
sys.stdin.readline()
close_participant(dp)
"""


def _table() -> ParameterTable:
    table = ParameterTable("robot1")
    table.declare("speed", 1.5)
    return table


def test_a_peer_with_another_type_is_reported_with_its_process(
    domain_id: int, caplog: pytest.LogCaptureFixture
) -> None:
    with DdsSession(domain_id) as session:
        server_dp = session.participant("paramdds-test-server")
        session.server(_table(), participant=server_dp)
        # positive control: a writer of our type matches the server's reader, nothing is reported
        peer = session.participant("paramdds-test-peer")
        topic = make_topic(peer, "GetParametersRequest", wire.GetParametersRequest)
        good = DataWriter(peer, topic, QosProfiles.load().writer("GetParametersRequest"))
        assert wait_until(lambda: good.get_publication_matched_status().current_count == 1, 5)
        # nor does a client's set: its volatile writer is rightly not matched by the server's
        # transient-local assignment reader on the same topic, which is not a mismatch
        client_dp = session.participant("paramdds-test-client")
        client = session.client(participant=client_dp)
        client.wait_for_node("robot1")
        assert client.set("robot1", {"speed": 2.0}).successful
        # nor does an assigner: its transient-local answer reader meets the server's volatile replies
        assigner_dp = session.participant("paramdds-test-assigner")
        answers: list[SetReply] = []
        assigner = Assigner(assigner_dp, on_reply=lambda reply, _error: answers.append(reply))
        try:
            assigner.assign("robot1", {"speed": 3.0})
            assert wait_until(lambda: answers != [], 5)
            assert [(r.name, r.successful) for r in answers[0].results] == [("speed", True)]
        finally:
            assigner.close()
        wait_until(lambda: False, 0.3)
        assert peer_mismatches(server_dp) == [] and peer_mismatches(client_dp) == []
        assert peer_mismatches(assigner_dp) == []
        with (
            caplog.at_level(logging.WARNING, logger="paramdds.peers"),
            subprocess.Popen(
                [sys.executable, "-c", _OLD_PEER, str(domain_id)],
                env=make_dds_env(domain_id),
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
            ) as old,
        ):
            assert old.stdin is not None and old.stdout is not None
            try:
                endpoint = old.stdout.readline().strip()
                assert wait_until(lambda: peer_mismatches(server_dp) != [], 10)
                old.stdin.write("\n")  # a sample on top: Cyclone raises the status again, no new report
                old.stdin.flush()
                assert old.stdout.readline().strip() == "wrote"
                wait_until(lambda: False, 0.3)
            finally:
                old.stdin.close()
                assert old.wait(timeout=10) == 0
        (found,) = peer_mismatches(server_dp)
        assert (found.topic, found.peer_kind, found.type_name) == (
            "GetParametersRequest",
            "writer",
            "paramdds::GetParametersRequest",
        )
        assert found.policy.startswith("TYPE_CONSISTENCY_ENFORCEMENT")
        assert (found.endpoint, found.pid, found.process) == (endpoint, str(old.pid), "odd-peer")
        warnings = [r.getMessage() for r in caplog.records if r.name == "paramdds.peers"]
        assert warnings == [found.message()]
        assert "'GetParametersRequest'" in warnings[0] and "'odd-peer'" in warnings[0]
        assert good.get_publication_matched_status().current_count == 1  # the good one still matches


def test_incompatible_qos_is_reported_on_both_sides(domain_id: int) -> None:
    with DdsSession(domain_id) as session:
        server_dp = session.participant("paramdds-test-server")
        session.server(_table(), participant=server_dp)
        monitor_dp = session.participant("paramdds-test-monitor")
        monitor = session.monitor(participant=monitor_dp)
        assert monitor.wait_synced(timeout=5)
        peer = DomainParticipant(domain_id)
        events = make_topic(peer, "ParameterEvents", wire.ParameterEvent)
        state = QosProfiles.load()
        # positive control: a reader with the State profile matches the server's writer
        good = DataReader(peer, events, state.reader("ParameterEvents"))
        assert wait_until(lambda: good.get_subscription_matched_status().current_count == 1, 5)
        # a reader asking for exclusive ownership: our writer offers shared
        exclusive = DataReader(peer, events, Qos(Policy.Reliability.Reliable(0), Policy.Ownership.Exclusive))
        # a best-effort state writer: the monitor's reader requests reliable
        best_effort = DataWriter(peer, events, Qos(Policy.Reliability.BestEffort))
        assert wait_until(lambda: len(peer_mismatches(server_dp)) == 1, 5)
        assert wait_until(lambda: len(peer_mismatches(monitor_dp)) >= 1, 5)
        (offered,) = peer_mismatches(server_dp)
        assert offered.endpoint == str(exclusive.guid)
        assert (offered.topic, offered.peer_kind, offered.policy) == (
            "ParameterEvents",
            "reader",
            "OWNERSHIP",
        )
        requested = {(m.endpoint, m.peer_kind, m.policy) for m in peer_mismatches(monitor_dp)}
        assert requested == {(str(best_effort.guid), "writer", "RELIABILITY")}
        assert monitor.snapshot()["robot1"].parameters["speed"][0].value == 1.5  # unharmed


def test_a_call_that_times_out_names_the_mismatched_peer(domain_id: int) -> None:
    """A node whose reply writer the client cannot match: the TIMEOUT says why, not only 'no answer'."""
    with DdsSession(domain_id) as session:
        client = session.client()  # first: its participant configures the domain (loopback)
        peer = DomainParticipant(domain_id)
        qos = QosProfiles.load()
        presence = DataWriter(
            peer, make_topic(peer, "ParameterEvents", wire.ParameterEvent), qos.writer("ParameterEvents")
        )
        presence.write(wire.ParameterEvent(node_id="odd", kind=wire.EVENT_PRESENCE, parameter_count=1))
        replies = make_topic(peer, "GetParametersResponse", wire.GetParametersResponse)
        best_effort = DataWriter(peer, replies, Qos(Policy.Reliability.BestEffort))
        client.wait_for_node("odd")  # present: the call waits for a reply instead of UNAVAILABLE
        with pytest.raises(CallTimeoutError) as failure:
            client.get("odd", ["x"], timeout=1.5)
        message = str(failure.value)
        assert "no answer from node 'odd'" in message
        assert "do not match" in message and str(best_effort.guid) in message and "RELIABILITY" in message
