"""The client's presence rule on real Cyclone (loopback, in process): when is a node "not present"?

:mod:`paramdds.dds.discovery` says a node never seen is absent only once discovery
has settled: a state writer was found, every matched one has delivered, and
discovery has been quiet. Each test first shows the path works (a present node is
ONLINE and answers), then holds one condition open and checks that a ghost is
UNKNOWN, never "not present", until it closes.
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import pytest
from cyclonedds.core import Entity
from cyclonedds.pub import DataWriter

from paramdds.core.table import ParameterTable
from paramdds.dds.discovery import PROBE_AFTER, Presence, is_quiet, is_settled
from paramdds.dds.qos import QosProfiles
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.errors import CallTimeoutError, UnavailableError

from .conftest import DDS, Proc, make_dds_env, wait


@pytest.mark.parametrize(
    ("writers", "pending", "burst", "quiet_for", "settled", "quiet"),
    [
        (1, 0, 0.0, 0.5, True, True),  # healthy loopback: known at once, then 0.5 s of quiet
        (1, 0, 0.0, 0.49, False, False),
        # no server found: never settled, the call's timeout decides; but quiet (rules 2, 3)
        (0, 0, 0.0, 60.0, False, True),
        (2, 1, 0.0, 60.0, False, False),  # a matched server that has delivered nothing
        (1, 0, 2.0, 1.9, False, False),  # slow discovery (changes over 2 s) needs 2 s of quiet
        (1, 0, 2.0, 2.0, True, True),
    ],
)
def test_the_rule(
    writers: int, pending: int, burst: float, quiet_for: float, settled: bool, quiet: bool
) -> None:
    assert is_settled(writers, pending, burst, quiet_for, min_quiet=0.5) is settled
    assert is_quiet(pending, burst, quiet_for, min_quiet=0.5) is quiet


@pytest.mark.slow
def test_a_state_writer_that_has_not_delivered_keeps_a_ghost_unknown(dds: DDS, domain_id: int) -> None:
    dds.server(domain_id, ParameterTable("present"))
    dp = dds.participant(domain_id)
    silent = DataWriter(
        dp,
        make_topic(dp, "ParameterEvents", wire.ParameterEvent),
        QosProfiles.load().writer("ParameterEvents"),
    )
    client = dds.client(domain_id)
    assert client.wait_for_node("present", timeout=5.0).online  # positive control
    assert client.presence("present") is Presence.ONLINE

    state = client.discovery()
    assert (state.state_writers, state.pending_writers) == (2, 1), state
    time.sleep(1.0)  # well past the quiet period: only the silent writer holds the answer back
    assert client.presence("ghost") is Presence.UNKNOWN
    with pytest.raises(CallTimeoutError, match="1 of 2 server"):
        client.get("ghost", ["x"], timeout=0.8)

    Entity.__del__(silent)  # it goes without ever having delivered: nothing is owed any more
    assert wait(lambda: client.presence("ghost") is Presence.ABSENT, timeout=5.0)
    started = time.monotonic()
    with pytest.raises(UnavailableError, match="'ghost' is not present"):
        client.get("ghost", ["x"], timeout=10.0)
    assert time.monotonic() - started < 0.5


@pytest.mark.slow
def test_with_no_parameter_server_anywhere_a_ghost_is_a_timeout_not_absent(dds: DDS, domain_id: int) -> None:
    client = dds.client(domain_id)
    started = time.monotonic()
    with pytest.raises(CallTimeoutError, match="no parameter server discovered"):
        client.get("ghost", ["x"], timeout=1.0)
    assert 1.0 <= time.monotonic() - started < 2.0  # the call's own timeout, no fixed grace
    with pytest.raises(CallTimeoutError, match="'late' not seen within"):
        client.wait_for_node("late", timeout=0.5)
    assert client.presence("late") is Presence.UNKNOWN

    dds.server(domain_id, ParameterTable("late"))  # the same client finds it once it exists
    assert client.wait_for_node("late", timeout=5.0).online
    assert client.list("late").names == ()
    assert wait(lambda: client.presence("ghost") is Presence.ABSENT, timeout=5.0)


@pytest.mark.slow
def test_waiting_for_a_node_asks_again_when_nobody_answered(dds: DDS, domain_id: int) -> None:
    """``wait_for_node`` keeps the discovery watch going, so it creates probes as calls do
    (a CI run at 30 % loss saw a fresh client wait 10 s for a node knowing nobody)."""
    client = dds.client(domain_id)
    failed: list[BaseException] = []

    def waiting() -> None:
        try:
            client.wait_for_node("nobody", timeout=PROBE_AFTER + 2.0)
        except CallTimeoutError as exc:
            failed.append(exc)

    waiter = threading.Thread(target=waiting)
    waiter.start()
    try:
        time.sleep(PROBE_AFTER + 1.0)
        watch = client.transport.discovery_watch
        probes = 0 if watch is None else watch.probes  # read while the wait still runs (no poll)
    finally:
        waiter.join()
    assert probes == 1
    assert len(failed) == 1 and "no parameter server discovered" in str(failed[0])


def test_a_node_that_went_away_is_offline_at_once(dds: DDS, domain_id: int) -> None:
    server = dds.server(domain_id, ParameterTable("brief"))
    client = dds.client(domain_id)
    assert client.wait_for_node("brief", timeout=5.0).online
    server.close()
    assert wait(lambda: client.presence("brief") is Presence.OFFLINE, timeout=5.0)
    with pytest.raises(UnavailableError, match="'brief' is offline"):
        client.wait_for_node("brief", timeout=0.3)


def test_a_busy_system_still_settles(dds: DDS, domain_id: int) -> None:
    table = ParameterTable("busy")
    table.declare("tick", 0)
    dds.server(domain_id, table)
    writer = dds.client(domain_id)
    assert writer.wait_for_node("busy", timeout=5.0).online
    stop = threading.Event()

    def churn() -> None:  # a parameter changing every 20 ms: updates, never new instances
        k = 0
        while not stop.is_set():
            k += 1
            writer.set("busy", {"tick": k})
            stop.wait(0.02)

    thread = threading.Thread(target=churn, daemon=True)
    thread.start()
    try:
        client = dds.client(domain_id)
        assert client.wait_for_node("busy", timeout=5.0).online  # positive control
        started = time.monotonic()
        with pytest.raises(UnavailableError, match="'ghost' is not present"):
            client.get("ghost", ["x"], timeout=10.0)
        assert time.monotonic() - started < 2.0
        assert writer.get_value("busy", "tick").value > 10  # it really was busy
    finally:
        stop.set()
        thread.join(5)


def test_a_long_lived_client_keeps_nothing_of_the_servers_that_left(dds: DDS, domain_id: int) -> None:
    """Server lives come and go under a long-lived client: its discovery watch holds no
    sample of a participant that left, and no record of a state writer that left (the soak's
    clients grew ~1.4 KB a departed participant, read and kept by the built-in reader)."""
    from paramdds.dds.participant import close_participant, make_participant
    from paramdds.dds.server import ParameterServer

    client = dds.client(domain_id)
    for k in range(3):
        dp = make_participant(domain_id, localhost=True, app_name=f"brief{k}")
        server = ParameterServer(dp)
        server.add_node(ParameterTable(f"brief{k}"))
        server.start()
        assert client.wait_for_node(f"brief{k}", timeout=5.0).online
        server.close()
        close_participant(dp)
        node = f"brief{k}"
        assert wait(lambda: client.presence(node) is Presence.OFFLINE, timeout=5.0)  # noqa: B023
    watch = client.transport.watch()
    assert wait(lambda: watch.state().state_writers == 0 and not watch._delivered, timeout=5.0)
    assert not watch._instance_of
    assert watch._participants.read(N=64) == []  # taken as they came: nothing kept of any


@pytest.mark.slow
def test_a_long_lived_client_needs_only_a_short_quiet_after_a_late_change(dds: DDS, domain_id: int) -> None:
    dds.server(domain_id, ParameterTable("first"))
    client = dds.client(domain_id)
    assert client.wait_for_node("first", timeout=5.0).online
    assert wait(lambda: client.presence("ghost") is Presence.ABSENT, timeout=5.0)
    time.sleep(2.0)  # a client that has been up for a while

    dds.server(domain_id, ParameterTable("second"))  # discovery changes again, late
    started = time.monotonic()
    assert client.wait_for_node("second", timeout=5.0).online
    with pytest.raises(UnavailableError, match="'ghost' is not present"):
        client.get("ghost", ["x"], timeout=10.0)
    # a new burst: 0.5 s of quiet, not as long again as the client's whole life
    assert time.monotonic() - started < 1.5


def test_presence_after_close_answers_without_touching_deleted_entities(dds: DDS, domain_id: int) -> None:
    dds.server(domain_id, ParameterTable("kept"))
    client = dds.client(domain_id)
    assert client.wait_for_node("kept", timeout=5.0).online
    client.close()
    client.close()  # twice is harmless
    assert client.presence("kept") is Presence.ONLINE  # the reader is the participant's, still there
    assert client.discovery().state_writers == 1


SILENT_WRITER = str(Path(__file__).with_name("silent_state_writer.py"))


@pytest.mark.slow
@pytest.mark.parametrize("lazy", [False, True], ids=["client", "lazy-client"])
def test_a_silent_server_is_waited_for_while_alive_and_not_once_killed(
    dds: DDS, domain_id: int, procs: list[Proc], lazy: bool
) -> None:
    """A remote state writer that owes its state holds a ghost UNKNOWN while it is alive
    (a slow server), and no longer once it is killed: about a second later (its 1 s
    liveliness lease), not after its 10 s participant lease, whatever the call's timeout.
    ``lazy``: the client creates its presence reader only after the kill (as the CLI's
    verbs do), so it matches a writer that is already not alive."""
    dds.server(domain_id, ParameterTable("present"))
    silent = Proc([sys.executable, SILENT_WRITER], make_dds_env(domain_id))
    procs.append(silent)
    silent.wait_for("ready", timeout=20)
    client = dds.client(domain_id, one_shot=lazy)
    if not lazy:
        assert client.wait_for_node("present", timeout=5.0).online  # positive control
        assert wait(lambda: client.discovery().state_writers == 2, timeout=5.0), client.discovery()
        time.sleep(1.5)  # past the liveliness lease: the silent writer is alive, it still owes its state
        state = client.discovery()
        assert (state.pending_writers, state.dead_writers) == (1, 0), state
        assert client.presence("ghost") is Presence.UNKNOWN
        with pytest.raises(CallTimeoutError, match="1 of 2 server"):
            client.get("ghost", ["x"], timeout=0.8)
    else:
        assert client.transport.discovery_watch is None  # no presence reader yet
        time.sleep(0.5)  # the client's participant has met the silent one (loopback: milliseconds)

    killed = silent.kill()
    with pytest.raises(UnavailableError, match="'ghost' is not present"):
        client.get("ghost", ["x"], timeout=10.0)
    assert time.monotonic() - killed < 1.5
    state = client.discovery()
    assert (state.state_writers, state.pending_writers, state.dead_writers) == (2, 0, 1), state
    assert client.presence("present") is Presence.ONLINE


@pytest.mark.slow
def test_a_client_that_knows_only_other_clients_asks_again(
    dds: DDS, domain_id: int, procs: list[Proc]
) -> None:
    """Probes are for "no parameter server yet", not "nobody yet": fresh CLI processes side by
    side know each other at once, and one whose server answers were all lost must still ask
    again (the rare lossy-link TIMEOUT of issue 24)."""
    peer = Proc([sys.executable, SILENT_WRITER, "--no-writer"], make_dds_env(domain_id))
    procs.append(peer)
    peer.wait_for("ready", timeout=20)
    client = dds.client(domain_id)
    assert wait(lambda: client.discovery().participants >= 1, timeout=5.0)  # it knows the peer
    with pytest.raises(CallTimeoutError, match=r"no parameter server discovered yet \(1 remote"):
        client.wait_for_node("nobody", timeout=PROBE_AFTER + 1.0)
    watch = client.transport.discovery_watch
    assert watch is not None and watch.probes == 1


@pytest.mark.parametrize("other", [True, False], ids=["another-server", "no-other-server"])
def test_a_process_about_to_serve_does_not_wait_for_its_own_empty_server(
    dds: DDS, domain_id: int, other: bool
) -> None:
    """The bridge's question before it mirrors anything: what do the *other* servers hold?
    Its own server hosts nothing yet and owes nothing: ignored, it no longer holds rule 2
    open, and "no other server" is an answer (``quiet``), where ``settled`` never is."""
    from paramdds.dds.server import ParameterServer

    own = dds.own(ParameterServer(dds.participant(domain_id)).start())
    if other:
        dds.server(domain_id, ParameterTable("elsewhere"))
    client = dds.client(domain_id)
    if other:
        assert client.wait_for_node("elsewhere", timeout=5.0).online
    time.sleep(1.0)  # past the quiet period: only our own empty server holds the answer back
    state = client.discovery()
    assert (state.state_writers, state.pending_writers, state.quiet) == (1 + other, 1, False), state

    client.ignore_writer(own.publication.writer)
    state = client.discovery()
    assert (state.state_writers, state.pending_writers, state.quiet) == (int(other), 0, True), state
    assert state.settled is other  # a client asking about a node still needs a server found
    assert client.presence("elsewhere") is (Presence.ONLINE if other else Presence.UNKNOWN)
