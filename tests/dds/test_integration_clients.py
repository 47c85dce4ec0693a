"""Request/reply correctness under concurrency (traps 2 and 3 of docs/wire.md).

Trap 2: clients that count request ids from 1 and match replies on
(node_id, request_id) steal each other's replies. Every client here counts from 1,
so only the client identity keeps them apart.

Trap 3: KEEP_LAST 1 request/reply topics lose messages when many are in flight,
and a TRANSIENT_LOCAL reply topic replays old replies to the next client run.
"""

from __future__ import annotations

import asyncio
import inspect
import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy
from cyclonedds.sub import DataReader

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.dds import client as client_module
from paramdds.dds._binding import matched_subscriptions
from paramdds.dds.client import AsyncParameterClient, ParameterClient
from paramdds.dds.qos import QosProfiles
from paramdds.dds.server import ParameterServer
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire
from paramdds.errors import UnavailableError

from .helpers import DdsSession, wait_until

pytestmark = pytest.mark.timeout(90)

NODE = "shared"
REPLY_TOPICS = ("SetParametersResponse", "GetParametersResponse", "ListParametersResponse")
REQUEST_TOPICS = ("SetParametersRequest", "GetParametersRequest", "ListParametersRequest")
WORKERS = 4  # two clients in this process, two in two other processes
ROUNDS = 300  # requests per worker, gets and sets interleaved


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def hammer(client: Any, node: str, k: int, rounds: int) -> dict[str, Any]:
    """Worker ``k``'s requests; every reply is checked against its own request.

    Worker k owns ``w{k}.p{j}`` (value k*1000+j, only read) and ``w{k}.v`` (only it
    writes): a reply meant for another worker carries another name or value.
    """
    errors: list[str] = []
    set_revisions: list[int] = []
    last = None
    for i in range(rounds):
        if i % 2 == 0:
            name = f"w{k}.p{i % 20}"
            reply = client.get(node, [name])
            found = [(r.name, None if r.value is None else r.value.value) for r in reply.results]
            if found != [(name, k * 1000 + i % 20)]:
                errors.append(f"get {name}: got {found}")
        else:
            last = k * 1_000_000 + i
            reply = client.set(node, {f"w{k}.v": last})
            outcome = [(r.name, r.successful) for r in reply.results]
            if outcome != [(f"w{k}.v", True)]:
                errors.append(f"set w{k}.v={last}: got {outcome}")
            set_revisions.append(reply.revision)
            if i % 25 == 1:
                got = client.get(node, [f"w{k}.v"]).results[0].value
                if got is None or got.value != last:
                    errors.append(f"read back w{k}.v: {got} != {last}")
    final = client.get(node, [f"w{k}.v"]).results[0].value
    return {
        "errors": errors,
        "set_revisions": set_revisions,
        "last": last,
        "final": None if final is None else final.value,
    }


_WORKER_SCRIPT = """
from __future__ import annotations
import json, sys
cfg = json.loads(sys.argv[1])
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import make_participant
{hammer}
dp = make_participant(cfg["domain"], localhost=True, app_name="paramdds-test-worker")
client = ParameterClient(dp, timeout=10.0)
client.wait_for_node(cfg["node"], timeout=10.0)
print("READY", flush=True)
sys.stdin.readline()  # go
print(json.dumps(hammer(client, cfg["node"], cfg["worker"], cfg["rounds"])), flush=True)
client.close()
from cyclonedds.core import Entity
Entity.__del__(dp)  # peers drop this participant now, not after its 10 s lease
"""


def _shared_table() -> ParameterTable:
    table = ParameterTable(NODE)
    for k in range(WORKERS):
        for j in range(20):
            table.declare(f"w{k}.p{j}", k * 1000 + j)
        table.declare(f"w{k}.v", 0)
    return table


def test_no_reply_stealing_between_clients_in_one_and_two_processes(dds: DdsSession) -> None:
    table = _shared_table()
    dds.server(table)
    start_revision = table.revision

    env = dict(os.environ, PARAMDDS_LOCALHOST="1")
    script = _WORKER_SCRIPT.format(hammer=inspect.getsource(hammer))
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-c",
                script,
                json.dumps({"domain": dds.domain_id, "node": NODE, "worker": k, "rounds": ROUNDS}),
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for k in (2, 3)
    ]
    try:
        for p in procs:
            assert p.stdout is not None
            assert p.stdout.readline().strip() == "READY", p.stderr.read() if p.stderr else ""

        participant = dds.participant()  # two clients sharing one participant
        local = [dds.client(participant, timeout=10.0) for _ in (0, 1)]
        results: dict[int, dict[str, Any]] = {}

        def run(k: int) -> None:
            results[k] = hammer(local[k], NODE, k, ROUNDS)

        threads = [threading.Thread(target=run, args=(k,)) for k in (0, 1)]
        for p in procs:  # go, all four at once
            assert p.stdin is not None
            p.stdin.write("go\n")
            p.stdin.flush()
        for t in threads:
            t.start()
        for k, p in zip((2, 3), procs, strict=True):
            out, err = p.communicate(timeout=60)
            assert p.returncode == 0, err
            results[k] = json.loads(out.strip().splitlines()[-1])
        for t in threads:
            t.join(60)
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.communicate()

    assert sorted(results) == [0, 1, 2, 3]
    all_revisions: list[int] = []
    for k, result in results.items():
        assert result["errors"] == [], (k, result["errors"][:5])
        revisions = result["set_revisions"]
        assert len(revisions) == ROUNDS // 2
        assert revisions == sorted(set(revisions)), f"worker {k}: revisions not increasing"
        assert result["final"] == result["last"]
        all_revisions += revisions
    # every set was applied exactly once and each reply names its own commit
    total_sets = WORKERS * (ROUNDS // 2)
    assert sorted(all_revisions) == list(range(start_revision + 1, start_revision + total_sets + 1))
    assert table.revision == start_revision + total_sets
    for k in range(WORKERS):
        assert table.get(f"w{k}.v").value == results[k]["last"]


def test_pipelined_burst_of_500_requests_all_answered(dds: DdsSession) -> None:
    table = ParameterTable("burst")
    table.declare("x", -1)
    for j in range(50):
        table.declare(f"g{j}", f"value-{j}")
    dds.server(table)
    sync = dds.client(timeout=15.0)
    sync.wait_for_node("burst", timeout=5.0)
    client = AsyncParameterClient(sync)
    start_revision = table.revision

    async def burst() -> list[Any]:
        calls = []
        for i in range(500):
            if i % 2:
                calls.append(client.set("burst", {"x": i}))
            else:
                calls.append(client.get("burst", [f"g{i % 50}", f"g{(i + 1) % 50}"]))
        return await asyncio.gather(*calls)

    replies = asyncio.run(burst())
    assert len(replies) == 500
    set_revisions: dict[int, int] = {}
    for i, reply in enumerate(replies):
        if i % 2:
            assert [(r.name, r.successful) for r in reply.results] == [("x", True)], i
            set_revisions[reply.revision] = i
        else:
            names = [f"g{i % 50}", f"g{(i + 1) % 50}"]
            assert [r.name for r in reply.results] == names, i
            assert [v.value for v in reply.values().values()] == [f"value-{n[1:]}" for n in names]
    # 250 distinct commits, none lost, none applied twice
    assert sorted(set_revisions) == list(range(start_revision + 1, start_revision + 251))
    assert table.revision == start_revision + 250
    # the value left is the one written by the last commit
    assert table.get("x").value == set_revisions[max(set_revisions)]


def test_next_client_run_never_receives_a_stale_reply(dds: DdsSession) -> None:
    table = ParameterTable("replay")
    table.declare("a", 0)
    table.declare("b", 0)
    table.declare("c", "c0", ParameterDescriptor("", dynamic_typing=True))
    dds.server(table)

    first = dds.client()
    first.wait_for_node("replay", timeout=5.0)
    for i in range(20):  # request ids 1..20 in every reply topic
        assert first.set("replay", {"a": i}).successful
        assert first.get("replay", ["a"]).values()["a"].value == i
        assert first.list("replay").names == ("a", "b", "c")
    first.close()

    # A late reader that asks for history (TRANSIENT_LOCAL) on each reply topic: with a
    # TRANSIENT_LOCAL reply writer it would be handed the first run's 20 replies.
    dp = dds.participant()
    late_qos = QosProfiles.load().assignment_reader()  # RELIABLE, TRANSIENT_LOCAL
    late = {name: DataReader(dp, make_topic(dp, name, wire.TOPICS[name]), late_qos) for name in REPLY_TOPICS}
    second = dds.client(dp)
    second.wait_for_node("replay", timeout=5.0)
    reply = second.set("replay", {"b": 42})  # request id 1 again
    assert [(r.name, r.successful) for r in reply.results] == [("b", True)]
    assert reply.revision == table.revision
    got = second.get("replay", ["b", "c"])  # request id 2
    assert [r.name for r in got.results] == ["b", "c"]
    assert got.values()["b"].value == 42
    assert second.list("replay", ["c"]).names == ("c",)
    for name, reader in late.items():
        stale = [s.request_id for s in reader.take(N=100) if s.sample_info.valid_data]
        assert stale == [], f"{name}: replies of the previous run were replayed"

    # and the reason, as discovery shows it: request/reply writers are VOLATILE (and keep a
    # deep KEEP_LAST history, so a dead reader that never acks cannot block them)
    publications = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    seen: dict[str, list[Any]] = {}

    def all_seen() -> bool:
        for p in publications.take(N=100):
            if p.sample_info.valid_data:
                seen.setdefault(p.topic_name, []).append(p.qos)
        # SetParametersResponse twice: the replies, and the answers to assignments
        return all(name in seen for name in (*REPLY_TOPICS, *REQUEST_TOPICS)) and (
            len(seen["SetParametersResponse"]) == 2
        )

    assert wait_until(all_seen, timeout=5.0), sorted(seen)
    for name in (*REPLY_TOPICS, *REQUEST_TOPICS):
        volatile = [q for q in seen[name] if q[Policy.Durability] == Policy.Durability.Volatile]
        assert volatile, name
        for qos in volatile:
            assert qos[Policy.History] == Policy.History.KeepLast(4096), name
            assert isinstance(qos[Policy.Reliability], Policy.Reliability.Reliable), name
    # the answers to assignments alone are kept, for an assigner that matches late (the newest
    # 16 per node); interactive clients never read them (a transient-local reader of its own)
    (kept,) = [q for q in seen["SetParametersResponse"] if q[Policy.Durability] != Policy.Durability.Volatile]
    assert kept[Policy.Durability] == Policy.Durability.TransientLocal
    assert kept[Policy.DurabilityService].history == Policy.History.KeepLast(16)
    assert kept[Policy.History] == Policy.History.KeepLast(4096)


def test_same_client_id_in_a_new_run_gets_its_own_replies(dds: DdsSession) -> None:
    """A client restarted with the same (forced) client_id counts request ids from 1 again:
    its requests must be applied and answered, not matched to the previous run's."""
    table = ParameterTable("again")
    table.declare("a", 0)
    dds.server(table)
    old = ParameterClient(dds.participant(), client_id=12345)
    old.wait_for_node("again", timeout=5.0)
    assert old.set("again", {"a": 1}).revision == table.revision
    old.close()

    new = dds.client(client_id=12345)
    new.wait_for_node("again", timeout=5.0)
    reply = new.set("again", {"a": 2})  # same client id, same request id, other content
    assert [(r.name, r.successful) for r in reply.results] == [("a", True)]
    assert table.get("a").value == 2
    assert reply.revision == table.revision


def test_raw_duplicate_request_is_applied_once(dds: DdsSession) -> None:
    """A retried request (same client and request id, same content) is answered again, not
    applied twice."""
    table = ParameterTable("dup")
    table.declare("n", 0)
    dds.server(table)
    client = dds.client()
    client.wait_for_node("dup", timeout=5.0)
    dp = dds.participant()
    qos = QosProfiles.load()
    writer = DataWriter(
        dp,
        make_topic(dp, "SetParametersRequest", wire.SetParametersRequest),
        qos.writer("SetParametersRequest"),
    )
    reader = DataReader(
        dp,
        make_topic(dp, "SetParametersResponse", wire.SetParametersResponse),
        qos.reader("SetParametersResponse"),
    )
    assert client.list("dup").names == ("n",)  # the server is serving
    start = table.revision
    request = wire.SetParametersRequest(
        node_id="dup",
        client_id=777,
        request_id=1,
        parameters=[wire.Parameter("n", wire.ParameterValue(type=2, integer_value=5))],
    )
    writer.write(request)
    writer.write(request)
    replies: list[Any] = []
    assert wait_until(
        lambda: replies.extend(s for s in reader.take(N=10) if s.client_id == 777) or len(replies) >= 2,
        timeout=5.0,
    )
    assert [r.revision for r in replies] == [start + 1, start + 1]
    assert table.revision == start + 1


@pytest.mark.parametrize("pause", [0.0, 0.3], ids=["started-at-once", "started-later"])
def test_a_request_sent_before_its_server_exists_is_resent_when_the_server_matches(
    dds: DdsSession, monkeypatch: pytest.MonkeyPatch, pause: float
) -> None:
    """A VOLATILE writer never delivers a sample to a reader it matches later: the first
    copy of a request sent while the server is still being discovered is lost. The client
    sends it again as soon as its writer matches a new reader; with the timed resend pushed
    past the call's timeout, that is the only way this call succeeds. ``pause``: what a loaded
    machine may take between building a server and starting it (its request readers, made in
    its constructor, matched while nothing was hosted and dropped that copy: CI timed out so)."""
    monkeypatch.setattr(client_module, "RESEND_AFTER", 60.0)
    client = dds.client(timeout=20.0)
    table = ParameterTable("late")
    table.declare("x", 7)
    replies: list[Any] = []
    call = threading.Thread(target=lambda: replies.append(client.get("late", ["x"])))
    call.start()
    assert not wait_until(lambda: bool(replies), timeout=0.3)  # nobody serves "late" yet
    server = ParameterServer(dds.participant("paramdds-test-server"))
    server.add_node(table)
    time.sleep(pause)
    server.start()
    try:
        call.join(timeout=20.0)
        assert [r.values()["x"].value for r in replies] == [7]
    finally:
        server.close()


def test_a_lazy_client_is_sent_no_state_until_a_call_needs_presence(dds: DdsSession) -> None:
    """A new ParameterEvents reader is sent every server's retained state: the CLI's
    one-shot client creates it only when a call needs presence, not for a prompt reply."""
    table = ParameterTable("lazy")
    for j in range(50):
        table.declare(f"p{j}", j)
    server = dds.server(table)

    def state_readers() -> int:
        return len(matched_subscriptions(server.publication.writer))

    lazy = dds.client(timeout=5.0, one_shot=True)
    assert lazy.get_value("lazy", "p7").value == 7
    assert state_readers() == 0  # answered without any state sent to this client
    with pytest.raises(UnavailableError, match="not present"):  # a call that needs presence
        lazy.get("ghost", ["x"], timeout=5.0)
    assert state_readers() == 1  # ... created the reader
    dds.client(timeout=5.0)  # positive control: an eager client's reader matches at once
    assert wait_until(lambda: state_readers() == 2, timeout=5.0)


def test_nodes_lists_a_node_its_server_stopped_hosting_as_offline(dds: DdsSession) -> None:
    """A node whose server stops hosting it (the ROS 2 bridge does so when a mirrored node
    leaves) leaves an invalid sample, with no data, beside the presence already read: the
    listing shows the node offline instead of failing on that sample."""
    gone, stays = ParameterTable("gone"), ParameterTable("stays")
    gone.declare("a", 1)
    stays.declare("b", 2)
    server = dds.server(gone, stays)
    client = dds.client()
    client.wait_for_node("gone", timeout=10)
    client.wait_for_node("stays", timeout=10)
    assert {n.node: n.online for n in client.nodes()} == {"gone": True, "stays": True}
    server.remove_node("gone")
    assert wait_until(lambda: client.presence("gone").value == "offline", 10), "'gone' never seen offline"
    assert {n.node: n.online for n in client.nodes()} == {"gone": False, "stays": True}
