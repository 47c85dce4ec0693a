"""QoS profiles: the packaged file, user files, and the autodispose trap on real DDS."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.util import duration

from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.qos import TOPIC_PROFILES, QosProfiles, default_path
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types
from paramdds.errors import ErrorCode, FileFormatError

SECOND = 1_000_000_000


@pytest.fixture(scope="module")
def profiles() -> QosProfiles:
    return QosProfiles.load()


def test_packaged_file_is_found_and_loads(profiles: QosProfiles) -> None:
    assert default_path().is_file()
    assert profiles.path == default_path()


@pytest.mark.parametrize(
    ("topic", "profile"),
    [
        ("ParameterEvents", "paramdds::State"),
        ("SetParametersRequest", "paramdds::Request"),
        ("GetParametersRequest", "paramdds::Request"),
        ("ListParametersRequest", "paramdds::Request"),
        ("SetParametersResponse", "paramdds::Reply"),
        ("GetParametersResponse", "paramdds::Reply"),
        ("ListParametersResponse", "paramdds::Reply"),
    ],
)
def test_topic_to_profile(profiles: QosProfiles, topic: str, profile: str) -> None:
    assert topic in types.TOPICS
    assert profiles.profile_for(topic) == profile


def test_every_topic_has_a_profile(profiles: QosProfiles) -> None:
    for topic in types.TOPICS:
        profiles.writer(topic)
        profiles.reader(topic)
    assert TOPIC_PROFILES[0] == ("ParameterEvents", "State")


def test_unknown_topic_is_refused(profiles: QosProfiles) -> None:
    with pytest.raises(ValueError, match="Bogus"):
        profiles.writer("Bogus")


def test_state_profile(profiles: QosProfiles) -> None:
    w = profiles.writer("ParameterEvents")
    r = profiles.reader("ParameterEvents")
    assert w[Policy.WriterDataLifecycle] == Policy.WriterDataLifecycle(autodispose=False)
    for q in (w, r):
        assert q[Policy.Durability] == Policy.Durability.TransientLocal
        assert q[Policy.History] == Policy.History.KeepLast(1)
        assert isinstance(q[Policy.Reliability], Policy.Reliability.Reliable)
    lease = w[Policy.Liveliness]
    assert isinstance(lease, Policy.Liveliness.Automatic)
    assert 0 < lease.lease_duration <= SECOND


@pytest.mark.parametrize("topic", ["GetParametersRequest", "SetParametersResponse"])
def test_request_and_reply_are_volatile_and_never_replace_undelivered(
    profiles: QosProfiles, topic: str
) -> None:
    # readers KEEP_ALL (bounded): nothing delivered is replaced before it is taken (trap 3);
    # writers a deep KEEP_LAST: a reader that never acks (a killed peer within its lease)
    # cannot make the writer block and starve every other client
    writer, reader = profiles.writer(topic), profiles.reader(topic)
    for q in (writer, reader):
        assert q[Policy.Durability] == Policy.Durability.Volatile
        assert isinstance(q[Policy.Reliability], Policy.Reliability.Reliable)
    assert reader[Policy.History] == Policy.History.KeepAll
    assert 0 < reader[Policy.ResourceLimits].max_samples <= 100_000
    assert writer[Policy.History] == Policy.History.KeepLast(4096)


def test_assignment_profile(profiles: QosProfiles) -> None:
    w, r = profiles.assignment_writer(), profiles.assignment_reader()
    assert w[Policy.WriterDataLifecycle] == Policy.WriterDataLifecycle(autodispose=False)
    for q in (w, r):
        assert q[Policy.Durability] == Policy.Durability.TransientLocal
        assert q[Policy.History] == Policy.History.KeepLast(1)
        assert isinstance(q[Policy.Reliability], Policy.Reliability.Reliable)


def test_user_file_loads(tmp_path: Path) -> None:
    copy = tmp_path / "mine.xml"
    copy.write_text(default_path().read_text().replace("<depth>1</depth>", "<depth>1</depth>", 1))
    assert QosProfiles.load(copy).profile_for("ParameterEvents") == "paramdds::State"


def test_missing_user_file(tmp_path: Path) -> None:
    missing = tmp_path / "nope.xml"
    with pytest.raises(FileFormatError) as err:
        QosProfiles.load(missing)
    assert str(missing) in str(err.value)
    assert err.value.code is ErrorCode.FILE_FORMAT


def test_malformed_user_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text('<dds>\n  <qos_library name="paramdds">\n</dds>\n')
    with pytest.raises(FileFormatError) as err:
        QosProfiles.load(bad)
    assert str(bad) in str(err.value)
    assert err.value.line == 3


def test_user_file_without_a_profile(tmp_path: Path) -> None:
    text = default_path().read_text().replace('<qos_profile name="Reply">', '<qos_profile name="Answer">')
    bad = tmp_path / "noreply.xml"
    bad.write_text(text)
    with pytest.raises(FileFormatError, match=r"paramdds::Reply") as err:
        QosProfiles.load(bad)
    assert str(bad) in str(err.value)


def test_user_file_cyclone_refuses(tmp_path: Path) -> None:
    text = default_path().read_text().replace("KEEP_ALL_HISTORY_QOS", "KEEP_EVERYTHING_QOS", 1)
    bad = tmp_path / "typo.xml"
    bad.write_text(text)
    with pytest.raises(FileFormatError) as err:
        QosProfiles.load(bad)
    assert str(bad) in str(err.value)


def test_loading_is_cheap() -> None:
    """Both the import and a load stay far below the CLI's start-up budget."""
    code = (
        "import time; t = time.perf_counter(); import paramdds.dds.qos as q; "
        "import cyclonedds.qos_provider; t1 = time.perf_counter(); q.QosProfiles.load(); "
        "print(time.perf_counter() - t1)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert float(out.stdout) < 0.05


# ---------------------------------------------------------------- real DDS


def _watch(
    participant: DomainParticipant,
    reader: DataReader,
    states: dict[str, int],
    names: dict[int, str],
    done: Callable[[dict[str, int]], bool],
    timeout: float = 5.0,
) -> dict[str, int]:
    """Update ``states`` (latest instance state per parameter name) until ``done(states)``.

    ``names`` maps instance handles to names: a state change without data (an
    invalid sample) carries only the handle.
    """
    waitset = WaitSet(participant)
    cond = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
    waitset.attach(cond)
    deadline = time.monotonic() + timeout
    try:
        while not done(states) and time.monotonic() < deadline:
            for sample in reader.take(N=100):
                info = sample.sample_info
                if info.valid_data:
                    names[info.instance_handle] = sample.name
                states[names[info.instance_handle]] = info.instance_state
            if not done(states):
                waitset.wait(duration(milliseconds=20))
    finally:
        waitset.detach(cond)
    return states


def _stop_writer_and_watch(domain_id: int, writer_qos: Qos, reader_qos: Qos) -> dict[str, int]:
    participant = make_participant(domain_id, localhost=True, app_name="test_qos")
    writer_side = make_participant(domain_id, localhost=True, app_name="test_qos_writer")
    try:  # both closed at the end: a participant left open keeps its domain id configured
        reader = DataReader(
            participant, make_topic(participant, "ParameterEvents", types.ParameterEvent), qos=reader_qos
        )
        topic = make_topic(writer_side, "ParameterEvents", types.ParameterEvent)
        writer = DataWriter(writer_side, topic, qos=writer_qos)
        for name in ("a", "b", "c"):
            writer.write(types.ParameterEvent(node_id="n1", name=name, revision=1))
        states: dict[str, int] = {}
        names: dict[int, str] = {}
        _watch(participant, reader, states, names, lambda s: len(s) == 3)
        assert states == dict.fromkeys("abc", InstanceState.Alive)
        del writer  # a graceful stop: deleting the writer unregisters its instances
        return _watch(participant, reader, states, names, lambda s: InstanceState.Alive not in s.values())
    finally:
        close_participant(writer_side)
        close_participant(participant)


def test_graceful_stop_leaves_instances_not_alive_no_writers(domain_id: int, profiles: QosProfiles) -> None:
    """Trap: with the default autodispose a stopping node looks like every parameter deleted."""
    states = _stop_writer_and_watch(
        domain_id, profiles.writer("ParameterEvents"), profiles.reader("ParameterEvents")
    )
    assert states == dict.fromkeys("abc", InstanceState.NotAliveNoWriters)


def test_default_autodispose_would_delete_everything(domain_id: int, profiles: QosProfiles) -> None:
    """The control: the same writer with Cyclone's default lifecycle disposes all instances."""
    naive = profiles.writer("ParameterEvents") + Qos(Policy.WriterDataLifecycle(autodispose=True))
    states = _stop_writer_and_watch(domain_id, naive, profiles.reader("ParameterEvents"))
    assert states == dict.fromkeys("abc", InstanceState.NotAliveDisposed)
