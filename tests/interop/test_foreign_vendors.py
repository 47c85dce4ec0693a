"""Other DDS implementations serve, read and call paramdds: real processes over loopback.

Each test runs once per vendor (``conftest.py`` builds the programs of
``examples/cyclone_c`` and ``examples/fastdds_cpp`` from ``idl/paramdds.idl``):

* a foreign monitor that joins late gets every parameter of a paramdds server,
  every type, each value exactly;
* a foreign client lists, gets and sets against a paramdds server (its replies
  are the ones echoing its client_id and request_id; a refused set is reported);
* a foreign node shows in ``paramdds nodes`` and ``paramdds watch``, answers
  ``paramdds get``/``set``/``list``, and a paramdds monitor sees it offline when it
  is killed.

Fast DDS knows no Cyclone discovery tags, so the paramdds side here runs without
the test run's tag (isolated by its domain id only), on paramdds's localhost
set-up: unicast to 127.0.0.1, participant indices 0..119. The foreign programs
join that set-up their own way: Cyclone C through ``CYCLONEDDS_URI`` (the very
configuration paramdds builds), Fast DDS through ``PARAMDDS_LOCALHOST=1`` (UDPv4
on 127.0.0.1, initial peers 127.0.0.1).
"""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.origin import local_identity
from paramdds.core.table import ParameterTable
from paramdds.core.values import ParameterValue
from paramdds.dds.monitor import EventKind
from paramdds.dds.participant import domain_config
from paramdds.errors import ErrorCode, NoHistoryError

from ..dds.helpers import DdsSession, wait_until
from .conftest import Vendor

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

PARAMDDS = str(Path(sys.executable).with_name("paramdds"))

# every type, with values that a lossy conversion would change
EVERY_TYPE: dict[str, object] = {
    "t.flag": False,
    "t.int_min": -(2**63),
    "t.int_max": 2**63 - 1,
    "t.tenth": 0.1,
    "t.tiny": 5e-324,
    "t.huge": -1.25e300,
    "t.text": 'héllo "quoted" \\ tab\t日本',
    "t.bytes": bytes([0, 7, 255]),
    "t.bools": [True, False],
    "t.ints": [1, -(2**63)],
    "t.doubles": [0.1, 1e-300],
    "t.strings": ["a", "", "ü"],
}


@pytest.fixture
def envs(monkeypatch: pytest.MonkeyPatch, domain_id: int) -> Iterator[tuple[dict[str, str], dict[str, str]]]:
    """(environment of the foreign program, of a paramdds command); this process untagged too."""
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)  # for DdsSession's participants
    base = {k: v for k, v in os.environ.items() if k != "CYCLONEDDS_URI"}
    base.update(PARAMDDS_DOMAIN=str(domain_id), PARAMDDS_LOCALHOST="1", PYTHONUNBUFFERED="1")
    foreign = dict(base, CYCLONEDDS_URI=domain_config(localhost=True) or "")
    yield foreign, base


def _run(cmd: list[str], env: dict[str, str], timeout: float = 30) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)


def _typed(kind: str, text: str) -> object:
    """A value printed by a foreign program (its type name, then JSON) as the Python value."""
    value = json.loads(text)
    if kind == "double":
        return float(value)
    if kind == "double_array":
        return [float(x) for x in value]
    if kind == "byte_array":
        return bytes(value)
    return value


def _lines(out: str, tag: str, fields: int = 4) -> list[list[str]]:
    return [line.split(" ", fields)[1:] for line in out.splitlines() if line.startswith(tag + " ")]


def test_a_foreign_monitor_joining_late_gets_every_value_exactly(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    _, program = vendor
    foreign_env, _ = envs
    table = ParameterTable("robot1")
    for name, value in EVERY_TYPE.items():
        table.declare(name, value)
    with DdsSession(domain_id) as session:
        server = session.server(table)
        done = _run([str(program), "monitor", "10"], foreign_env)  # starts after the server: late
        incarnation = server.incarnation("robot1")
    assert done.returncode == 0, done.stderr
    seen: dict[str, object] = {}
    for node, name, kind, text in _lines(done.stdout, "PARAM"):
        assert node == "robot1"
        assert kind == ParameterValue.from_python(EVERY_TYPE[name]).type.label, name
        seen[name] = _typed(kind, text)
    assert seen == EVERY_TYPE  # every parameter, every value exactly (0.1, 5e-324, the int64 limits)
    ((node, _host, pid, rest),) = _lines(done.stdout, "NODE")
    _revision, count, seen_incarnation = rest.split()
    assert (node, pid, count) == ("robot1", str(os.getpid()), str(len(EVERY_TYPE)))
    assert incarnation != 0 and seen_incarnation == f"{incarnation:016x}"  # the new last member, read


def test_a_foreign_monitor_reads_who_changed_each_value_of_a_paramdds_node(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    """The blame members paramdds writes, read by another vendor: a start value is the
    server's own (verified, via start), a set the asker's claim (via api, unverified)."""
    _, program = vendor
    table = ParameterTable("robot1")
    table.declare("robot.speed", 1.5)
    table.declare("robot.name", "rx")
    with DdsSession(domain_id) as session:
        session.server(table)
        changed = session.client(as_="ops@lab").set("robot1", {"robot.speed": 2.5})
        done = _run([str(program), "monitor", "10"], envs[0])
    assert done.returncode == 0, done.stderr
    start = changed.revision - 1
    assert {rest[1]: rest for rest in _lines(done.stdout, "BLAME", 6)} == {
        "robot.speed": ["robot1", "robot.speed", "api", "claimed", str(changed.revision), "ops@lab"],
        "robot.name": ["robot1", "robot.name", "start", "verified", str(start), local_identity()],
    }


def test_a_foreign_client_lists_gets_and_sets_on_a_paramdds_server(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    _, program = vendor
    foreign_env = dict(envs[0], PARAMDDS_AS="peer-client")  # the identity its sets claim
    table = ParameterTable("robot1")
    table.declare(
        "robot.speed",
        1.5,
        ParameterDescriptor("robot.speed", floating_point_range=FloatingPointRange(0.0, 5.0)),
    )
    table.declare("robot.name", "rx")
    table.declare("sensor.rate", 30)
    with DdsSession(domain_id) as session:
        session.server(table)
        listed = _run([str(program), "list", "robot1"], foreign_env)
        assert listed.returncode == 0, listed.stderr
        assert [n for (n,) in _lines(listed.stdout, "NAME")] == ["robot.name", "robot.speed", "sensor.rate"]

        got = _run([str(program), "get", "robot1", "robot.speed", "robot.name", "nope"], foreign_env)
        assert got.returncode == 1, got.stderr  # one name is missing: reported, not dropped
        assert [(n, k, t) for n, k, t in _lines(got.stdout, "VALUE")] == [
            ("robot.speed", "double", "1.5"),
            ("robot.name", "string", '"rx"'),
        ]
        assert _lines(got.stdout, "MISSING") == [["nope", "NOT_FOUND"]]

        done = _run([str(program), "set", "robot1", "robot.speed=2.5", "sensor.rate=60"], foreign_env)
        assert done.returncode == 0, done.stdout + done.stderr
        assert _lines(done.stdout, "RESULT") == [["robot.speed", "OK"], ["sensor.rate", "OK"]]
        assert (table.get("robot.speed").value, table.get("sensor.rate").value) == (2.5, 60)

        refused = _run([str(program), "set", "robot1", "robot.speed=9.5"], foreign_env)
        assert refused.returncode == 1
        ((name, verdict, code, _reason),) = _lines(refused.stdout, "RESULT")
        assert (name, verdict, code) == ("robot.speed", "FAILED", "OUT_OF_RANGE")
        assert table.get("robot.speed").value == 2.5  # unchanged

        # the server recorded each write under the foreign client's claim (via "api",
        # unverified), the refused one too
        records = session.client().history("robot1", timeout=10).records
        assert [
            (r.name, r.who, r.verified, r.via, r.applied, r.code) for r in records if r.via != "start"
        ] == [
            ("robot.speed", "peer-client", False, "api", True, ""),
            ("sensor.rate", "peer-client", False, "api", True, ""),
            ("robot.speed", "peer-client", False, "api", False, "OUT_OF_RANGE"),
        ]


class _Node:
    """A foreign node process: started, waited for (READY), killed with SIGKILL at the end."""

    def __init__(self, program: Path, node: str, env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(
            [str(program), "node", node], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        assert line.strip() == "READY", line + (self.proc.stderr.read() if self.proc.stderr else "")
        self.output: str | None = None

    def kill(self) -> str:
        """Kill the node (if it still runs); what it printed."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        if self.output is None:
            self.output = self.proc.communicate(timeout=10)[0]
        return self.output


def _state_of(node: str, env: dict[str, str]) -> str:
    """A node's "INCARNATION:REVISION" from `paramdds nodes -o json` (asked until it shows)."""
    for _ in range(5):
        found = [
            n for n in json.loads(_run([PARAMDDS, "nodes", "-o", "json"], env).stdout) if n["node"] == node
        ]
        if found:
            return str(found[0]["at"])
    raise AssertionError(f"{node} not listed by `paramdds nodes`")


def test_a_foreign_node_is_served_by_the_paramdds_tools(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    info, program = vendor
    foreign_env, cli_env = envs
    p = info.prefix
    node = _Node(program, "fnode", foreign_env)
    try:
        # `nodes` shows what discovery has found when it runs; a Fast DDS participant is
        # sometimes found ~1 s after a new one starts, so ask until it shows (at most 5 tries)
        rows: list[Any] = []
        listed: list[Any] = []
        for _ in range(5):
            listed = json.loads(_run([PARAMDDS, "nodes", "-o", "json"], cli_env).stdout)
            rows = [(n["node"], n["online"], n["parameters"], n["pid"], n["request_filter"]) for n in listed]
            if rows:
                break
        assert rows == [("fnode", True, 4, node.proc.pid, None)]  # its presence says nothing of filtering
        # the foreign node's own incarnation, read from its presence (the new last member)
        incarnation = str(listed[0]["incarnation"])
        assert listed[0]["at"] == f"{incarnation}:1" and int(incarnation, 16) != 0
        got = _run([PARAMDDS, "get", "fnode", f"{p}speed", f"{p}count", "-o", "json"], cli_env)
        assert (got.returncode, json.loads(got.stdout)) == (0, {f"{p}speed": 1.5, f"{p}count": 3}), got.stderr
        names = _run([PARAMDDS, "list", "fnode", "-o", "json"], cli_env)
        assert json.loads(names.stdout) == sorted(f"{p}{n}" for n in ("speed", "count", "label", "enabled"))
        done = _run([PARAMDDS, "set", "fnode", f"{p}speed=2.5", f"{p}label=on-ice", "-o", "json"], cli_env)
        assert done.returncode == 0, done.stdout + done.stderr
        result: dict[str, Any] = json.loads(done.stdout)
        assert result["revision"] == 2 and result[f"{p}speed"]["successful"]

        # compare-and-set on the foreign node's (incarnation, revision): a wrong incarnation is
        # refused although the revision matches, the right one applies
        # (the node's value is what is checked; `nodes` may show the revision before the last set)
        for _ in range(3):
            at = _state_of("fnode", cli_env)
            assert at.startswith(incarnation + ":")  # the same start: the incarnation holds
            other = f"{int(incarnation, 16) ^ 1:016x}:{at.partition(':')[2]}"
            stale = _run([PARAMDDS, "set", "fnode", f"{p}count=5", "--if-revision", other], cli_env)
            # the revision matches, the start does not: refused, nothing applied
            assert (stale.returncode, _count_of(p, cli_env)) == (1, 3), stale.stdout + stale.stderr
            _run([PARAMDDS, "set", "fnode", f"{p}count=4", "--if-revision", at], cli_env)
            if _count_of(p, cli_env) == 4:
                break
        assert _count_of(p, cli_env) == 4  # applied on the right (incarnation, revision)
        refused = _run([PARAMDDS, "set", "fnode", f"{p}speed=true"], cli_env)  # the node checks types
        assert refused.returncode == 1 and "TYPE" in refused.stdout + refused.stderr.upper()

        watch = subprocess.Popen(
            [PARAMDDS, "watch", "fnode", "-o", "json"], env=cli_env, stdout=subprocess.PIPE, text=True
        )
        try:
            assert watch.stdout is not None
            added: dict[str, object] = {}
            while len(added) < 4:
                event = json.loads(watch.stdout.readline())
                if event["event"] == "added":
                    added[event["name"]] = event["value"]
            assert added == {f"{p}speed": 2.5, f"{p}count": 4, f"{p}label": "on-ice", f"{p}enabled": True}
        finally:
            watch.terminate()
            watch.communicate(timeout=10)

        with DdsSession(domain_id) as session:
            monitor = session.monitor()
            # the node's parameters may arrive before its presence: wait for both
            assert wait_until(lambda: getattr(monitor.snapshot().get("fnode"), "online", False), 10)
            offline: list[str] = []
            monitor.add_callback(lambda e: offline.append(e.node) if e.event is EventKind.OFFLINE else None)
            node.kill()
            assert wait_until(lambda: offline == ["fnode"], 10)  # the node's lease, ~1-2 s
            assert monitor.snapshot()["fnode"].parameters[f"{p}speed"][0].value == 2.5  # last values kept
    finally:
        node.kill()


def _count_of(prefix: str, cli_env: dict[str, str]) -> object:
    """The foreign node's ``count``, read by ``paramdds get`` (its error shown if it fails)."""
    got = _run([PARAMDDS, "get", "fnode", f"{prefix}count", "-o", "json"], cli_env)
    assert got.returncode == 0, got.stderr
    return json.loads(got.stdout)[f"{prefix}count"]


def _count_set(prefix: str, client_id: int, request_id: int, value: int, deadline: int = 0) -> Any:
    """A SetParametersRequest of the foreign node's ``count`` (no revision expected)."""
    from paramdds.dds.wire import types as wire

    return wire.SetParametersRequest(
        node_id="fnode",
        client_id=client_id,
        request_id=request_id,
        expected_revision=-1,
        parameters=[wire.Parameter(f"{prefix}count", wire.ParameterValue(type=2, integer_value=value))],
        deadline=deadline,
    )


@contextlib.contextmanager
def _node_and_peer(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> Iterator[tuple[str, _Node, Any]]:
    """A foreign node "fnode" and a raw peer beside it: (its parameters' prefix, node, peer)."""
    from ..reliability.rawwire import RawPeer

    info, program = vendor
    node = _Node(program, "fnode", envs[0])
    try:
        with DdsSession(domain_id) as session:
            yield info.prefix, node, RawPeer(session.participant())
    finally:
        node.kill()


def test_a_foreign_node_refuses_a_set_past_its_deadline(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    """The deadline (the last member of SetParametersRequest) read by another vendor's node:
    past it, EXPIRED with nothing applied; with time left, applied."""
    cli_env = envs[1]
    with _node_and_peer(vendor, envs, domain_id) as (p, _node, peer):
        late = peer.first_answer(_count_set(p, 99, 1, 7, time.time_ns() - 1_000_000_000))
        assert late.code == "EXPIRED" and "after its deadline" in late.reason, late
        assert _count_of(p, cli_env) == 3  # nothing applied
        in_time = peer.first_answer(_count_set(p, 99, 2, 7, time.time_ns() + 10_000_000_000))
        assert in_time.code == "" and in_time.results[0].successful, in_time
        assert _count_of(p, cli_env) == 7


def test_a_foreign_node_applies_a_resent_set_once(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    """Clients resend a set while discovery settles: the example peers answer the same
    (client_id, request_id) with their first answer and apply it once (they keep 64)."""
    with _node_and_peer(vendor, envs, domain_id) as (p, node, peer):
        request = _count_set(p, 77, 1, 9)
        peer.first_answer(request)
        answered = len(peer.replies(request, 1, timeout=0))
        for _ in range(3):
            peer.send(request)
        answers = peer.replies(request, answered + 3, timeout=5.0)
    assert len(answers) >= answered + 3
    assert [(a.revision, a.results[0].successful) for a in answers] == [(2, True)] * len(answers)
    assert node.kill().splitlines().count(f"SET {p}count") == 1  # the node applied it once


def test_a_foreign_node_stamps_each_change_with_the_askers_claim(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    """Blame on another vendor's node, read by paramdds's reader: its start values are its own
    (via start, verified), a change carries the asker's claim unverified, a change from an asker that says
    nothing carries "" (no last change); its get with descriptors and its own monitor say the
    same, and its client's set says who and via "api"."""
    from cyclonedds.sub import DataReader

    from paramdds.dds.qos import QosProfiles
    from paramdds.dds.topics import make_topic
    from paramdds.dds.wire import types as wire

    from ..reliability.rawwire import RawPeer

    info, program = vendor
    p = info.prefix
    node_env = dict(envs[0], PARAMDDS_AS="peer-node")
    node = _Node(program, "fnode", node_env)
    try:
        with DdsSession(domain_id) as session:
            dp = session.participant()
            peer = RawPeer(dp)
            state_reader = DataReader(
                dp,
                make_topic(dp, "ParameterEvents", wire.ParameterEvent),
                QosProfiles.load().reader("ParameterEvents"),
            )
            state: dict[str, Any] = {}

            def blame(name: str) -> tuple[str, bool, str, int] | None:
                """(who, verified, via, revision) of the parameter's state as read last."""
                for s in state_reader.take(N=64):
                    if s.sample_info.valid_data and s.kind == wire.EVENT_PARAMETER:
                        state[s.name] = s
                s = state.get(f"{p}{name}")
                return None if s is None else (s.who, s.verified, s.via, s.revision)

            def becomes(name: str, expected: tuple[str, bool, str, int] | None) -> bool:
                return wait_until(lambda: blame(name) == expected, 10)

            assert wait_until(lambda: blame("enabled") is not None and len(state) == 4, 10), state
            for name in ("speed", "count", "label", "enabled"):  # its own start values
                assert blame(name) == ("peer-node", True, "start", 1), name

            claimed = _count_set(p, 55, 1, 5)
            claimed.who, claimed.via = "alice@lab", "api"
            assert peer.first_answer(claimed).results[0].successful
            assert becomes("count", ("alice@lab", False, "api", 2)), blame("count")
            silent = wire.SetParametersRequest(  # who and via "": a peer that says nothing
                node_id="fnode",
                client_id=55,
                request_id=2,
                expected_revision=-1,
                parameters=[wire.Parameter(f"{p}label", wire.ParameterValue(type=4, string_value="quiet"))],
            )
            assert peer.first_answer(silent).results[0].successful
            assert becomes("label", ("", False, "", 3)), blame("label")
            # paramdds's monitor and describe read the same: no last change where who is ""
            monitor = session.monitor()
            assert wait_until(lambda: monitor.last_change("fnode", f"{p}count") is not None, 10)
            seen = monitor.last_change("fnode", f"{p}count")
            assert seen is not None and (seen.who, seen.verified, seen.via, seen.revision) == (
                "alice@lab",
                False,
                "api",
                2,
            )
            assert monitor.last_change("fnode", f"{p}label") is None
            shown = _run([PARAMDDS, "describe", "fnode", f"{p}count", f"{p}label", "-o", "json"], envs[1])
            assert shown.returncode == 0, shown.stderr
            lasts = {name: d["last_change"] for name, d in json.loads(shown.stdout).items()}
            assert lasts[f"{p}label"] is None and lasts[f"{p}count"]["who"] == "alice@lab"

            described = peer.first_answer(
                wire.GetParametersRequest(
                    node_id="fnode",
                    client_id=55,
                    request_id=3,
                    with_descriptors=True,
                    names=[f"{p}count", f"{p}label"],
                )
            )
            (count,), unknown = (r.last_change for r in described.results)
            assert (count.who, count.verified, count.via, count.revision) == ("alice@lab", False, "api", 2)
            assert unknown == []  # who changed it last is not known: no last change
            assert count.stamp == state[f"{p}count"].stamp  # when: the state's stamp

            # the node keeps no history: a history query is answered at once, history_kept FALSE
            started = time.monotonic()
            answer = peer.first_answer(
                wire.GetParametersRequest(
                    node_id="fnode", client_id=55, request_id=4, history=[wire.HistoryQuery()]
                )
            )
            assert time.monotonic() - started < 3
            assert (answer.history_kept, answer.history, answer.history_more, answer.history_compacted) == (
                False,
                [],
                False,
                False,
            )

            # its own client says who (its claim) and via "api"; the node records them
            client_env = dict(envs[0], PARAMDDS_AS="peer-client")
            done = _run([str(program), "set", "fnode", f"{p}speed=4.5"], client_env)
            assert done.returncode == 0, done.stdout + done.stderr
            assert becomes("speed", ("peer-client", False, "api", 4)), blame("speed")

        # the vendor's own monitor prints each state's blame; "" prints none
        printed = _run([str(program), "monitor", "5"], envs[0])
        assert printed.returncode == 0, printed.stderr
        assert {rest[1]: rest for rest in _lines(printed.stdout, "BLAME", 6)} == {
            f"{p}speed": ["fnode", f"{p}speed", "api", "claimed", "4", "peer-client"],
            f"{p}count": ["fnode", f"{p}count", "api", "claimed", "2", "alice@lab"],
            f"{p}enabled": ["fnode", f"{p}enabled", "start", "verified", "1", "peer-node"],
        }
    finally:
        node.kill()


def test_history_of_a_foreign_node_fails_fast_saying_it_keeps_none(
    vendor: tuple[Vendor, Path], envs: tuple[dict[str, str], dict[str, str]], domain_id: int
) -> None:
    """A node of another vendor keeps no history: paramdds's client says so at once
    (NO_HISTORY), never waits for its timeout, and so do `history`, `diff NODE@REV` and
    `watch --since` (one line, exit 1); its get with descriptors carries each parameter's
    last change, which paramdds reads."""
    info, program = vendor
    p = info.prefix
    node = _Node(program, "fnode", dict(envs[0], PARAMDDS_AS="peer-node"))
    try:
        with DdsSession(domain_id) as session:
            client = session.client()
            assert wait_until(lambda: any(n.node == "fnode" for n in client.nodes()), 10)
            started = time.monotonic()
            with pytest.raises(NoHistoryError) as raised:
                client.history("fnode", [f"{p}speed"], timeout=20)
            assert time.monotonic() - started < 5  # answered, not timed out
            assert raised.value.code is ErrorCode.NO_HISTORY and "keeps no history" in str(raised.value)

            # the verbs that read history say so in one line, exit 1 (a timeout would be exit 3)
            for verb in (
                ["history", "fnode"],
                ["diff", "fnode@1", "fnode"],
                ["watch", "fnode", "--since", "1"],
            ):
                done = _run([PARAMDDS, *verb, "--timeout", "20"], envs[1])
                assert (done.returncode, done.stdout) == (1, ""), verb
                assert (
                    done.stderr
                    == "paramdds: error: node 'fnode' keeps no history (a peer that does not record it)\n"
                )

            client.set("fnode", {f"{p}count": 8}, as_="bob@lab", timeout=10)
            got = client.get("fnode", [f"{p}speed", f"{p}count"], with_descriptors=True, timeout=10)
            speed, count = (r.last_change for r in got.results)
            assert speed is not None and (speed.who, speed.verified, speed.via, speed.revision) == (
                "peer-node",
                True,
                "start",
                1,
            )
            assert count is not None and (count.who, count.verified, count.via, count.revision) == (
                "bob@lab",
                False,
                "api",
                2,
            )
    finally:
        node.kill()
