"""What a caller is told about a write is true (issue 29, item 1).

A write is reported failed only when it was not applied and never will be; a caller
that stops waiting after sending it says OUTCOME_UNKNOWN, and the node never applies
it after its deadline (one host: one clock). Every test runs real processes on a
domain of its own: a server (``stalling_server.py``) whose node stops itself with
SIGSTOP inside a set, after the request reached it and before the commit; the test
sends SIGCONT once the caller has given up, then reads the node back. A get is queued
behind the node's sets, so its answer comes after the resumed set was decided.
"""

from __future__ import annotations

import asyncio
import json
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from paramdds.dds.client import AsyncParameterClient
from paramdds.dds.wire import types as wire
from paramdds.errors import ErrorCode, ExpiredError, OutcomeUnknownError, UnavailableError

from ..web._support import Console
from .conftest import DDS, PARAMDDS, Proc, make_dds_env
from .rawwire import RawPeer

SERVER = str(Path(__file__).with_name("stalling_server.py"))
NODE = "robot1"
START = {"robot.speed": 1.0, "robot.mode": "auto", "extra.note": "keep"}


class Stalling:
    """The stalling server: started, resumed (SIGCONT) and stopped."""

    def __init__(self, domain: int) -> None:
        self.proc = Proc([sys.executable, "-u", SERVER, str(domain)], make_dds_env(domain))
        self.proc.wait_for("READY", 20)

    def wait_stopped(self, timeout: float = 15.0) -> None:
        """Until the node has stopped itself inside a set."""
        self.proc.wait_for("STOPPING", timeout)
        stat = Path(f"/proc/{self.proc.pid}/stat")
        end = time.monotonic() + 5
        while stat.read_text().rpartition(")")[2].split()[0] not in ("T", "t"):
            assert time.monotonic() < end, "the server did not stop"
            time.sleep(0.01)

    def resume(self) -> None:
        self.proc.popen.send_signal(signal.SIGCONT)

    def close(self) -> None:
        self.resume()
        self.proc.stop()


@pytest.fixture
def stalling(domain_id: int) -> Iterator[Stalling]:
    server = Stalling(domain_id)
    try:
        yield server
    finally:
        server.close()


def state_after_resume(dds: DDS, domain: int, stalling: Stalling) -> tuple[dict[str, Any], int]:
    """SIGCONT, then the node's values and revision (read once the resumed set is decided)."""
    stalling.resume()
    client = dds.client(domain)
    reply = client.get(NODE, list(START), timeout=10)
    values = {r.name: r.value.to_python() if r.value is not None else None for r in reply.results}
    return values, reply.revision


def cli(domain: int, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PARAMDDS, *args], env=make_dds_env(domain), capture_output=True, text=True, timeout=60
    )


# -- the CLI: exit 5 (outcome unknown), and the value never changes afterwards -----------------------

CLI_WRITES = {
    "set": ["set", NODE, "robot.speed=2.5"],
    "atomic set": ["set", NODE, "robot.speed=2.5", "robot.mode=manual", "--atomic"],
    "delete": ["delete", NODE, "extra.note"],
    "load": ["load", NODE, "{file}"],
}


@pytest.mark.slow
@pytest.mark.parametrize("write", list(CLI_WRITES))
def test_cli_write_stalled_on_the_node_is_outcome_unknown_and_never_applied_later(
    write: str, domain_id: int, stalling: Stalling, dds: DDS, tmp_path: Path
) -> None:
    params = tmp_path / "params.yaml"
    params.write_text(f"{NODE}:\n  ros__parameters:\n    robot:\n      speed: 2.5\n      mode: manual\n")
    args = [a.replace("{file}", str(params)) for a in CLI_WRITES[write]]
    before = dds.client(domain_id).get(NODE, list(START), timeout=10).revision
    started = time.monotonic()
    done = cli(domain_id, *args, "--timeout", "2")
    stalling.wait_stopped(1)  # it stopped inside the set, before the commit
    assert done.returncode == 5, (done.returncode, done.stderr)  # neither 3 (UNAVAILABLE) nor 1
    assert "outcome unknown" in done.stderr and time.monotonic() - started >= 2.0
    values, revision = state_after_resume(dds, domain_id, stalling)
    assert values == START and revision == before  # refused on resume (EXPIRED): nothing applied


# -- the Python API, sync and async ---------------------------------------------------------------


def _api_write(kind: str, client: Any) -> Any:
    if kind == "set":
        return client.set(NODE, {"robot.speed": 2.5}, timeout=1.5)
    if kind == "atomic set":
        return client.set(NODE, {"robot.speed": 2.5, "robot.mode": "manual"}, atomic=True, timeout=1.5)
    if kind == "delete":
        return client.delete(NODE, ["extra.note"], timeout=1.5)
    raise AssertionError(kind)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["set", "atomic set", "delete"])
def test_api_write_stalled_on_the_node_is_outcome_unknown_and_never_applied_later(
    kind: str, domain_id: int, stalling: Stalling, dds: DDS
) -> None:
    client = dds.client(domain_id)
    before = client.get(NODE, list(START), timeout=10).revision
    with pytest.raises(OutcomeUnknownError) as raised:
        _api_write(kind, client)
    assert raised.value.code is ErrorCode.OUTCOME_UNKNOWN and "may or may not have been applied" in str(
        raised.value
    )
    stalling.wait_stopped(1)
    values, revision = state_after_resume(dds, domain_id, stalling)
    assert values == START and revision == before


@pytest.mark.slow
def test_async_api_set_stalled_is_outcome_unknown(domain_id: int, stalling: Stalling, dds: DDS) -> None:
    client = AsyncParameterClient(dds.client(domain_id))
    before = client.sync.get(NODE, list(START), timeout=10).revision

    async def write() -> Any:
        return await client.set(NODE, {"robot.speed": 2.5}, timeout=1.5)

    with pytest.raises(OutcomeUnknownError):
        asyncio.run(write())
    stalling.wait_stopped(1)
    values, revision = state_after_resume(dds, domain_id, stalling)
    assert values == START and revision == before


@pytest.mark.slow
def test_a_stall_that_ends_before_the_wait_does_is_expired(
    domain_id: int, stalling: Stalling, dds: DDS
) -> None:
    """Resumed after the deadline but before the caller stops waiting: a true refusal, EXPIRED."""
    client = dds.client(domain_id)
    before = client.get(NODE, list(START), timeout=10).revision
    result: list[BaseException] = []

    def write() -> None:
        try:
            client.set(NODE, {"robot.speed": 2.5}, timeout=4.0)  # deadline at 3.8 s, wait 4.0 s
        except BaseException as exc:
            result.append(exc)

    thread = threading.Thread(target=write)
    started = time.monotonic()
    thread.start()
    stalling.wait_stopped(10)
    time.sleep(max(0.0, started + 3.85 - time.monotonic()))  # past the deadline, before the wait ends
    stalling.resume()
    thread.join(10)
    (error,) = result
    if isinstance(error, OutcomeUnknownError):  # the reply lost the race with the wait's end
        pytest.skip("the resumed node answered after the caller's wait ended (machine too loaded)")
    assert isinstance(error, ExpiredError) and "after its deadline" in str(error)
    values, revision = state_after_resume(dds, domain_id, stalling)
    assert values == START and revision == before


def test_a_write_to_a_node_known_offline_is_not_sent(domain_id: int, stalling: Stalling, dds: DDS) -> None:
    client = dds.client(domain_id)
    before = client.get(NODE, list(START), timeout=10).revision
    stalling.proc.popen.send_signal(signal.SIGSTOP)
    deadline = time.monotonic() + 10
    while client.node_info(NODE) is None or client.node_info(NODE).online:  # type: ignore[union-attr]
        assert time.monotonic() < deadline
        time.sleep(0.05)
    with pytest.raises(UnavailableError, match="not sent"):
        client.set(NODE, {"robot.speed": 2.5}, timeout=1.5)
    values, revision = state_after_resume(dds, domain_id, stalling)
    assert values == START and revision == before


# -- the web console: POST /api/set answers 504 OUTCOME_UNKNOWN --------------------------------------


@pytest.mark.slow
def test_web_set_stalled_on_the_node_is_504_outcome_unknown(
    domain_id: int, stalling: Stalling, dds: DDS
) -> None:
    before = dds.client(domain_id).get(NODE, list(START), timeout=10).revision
    console = Console(domain_id)
    try:
        end = time.monotonic() + 20
        while True:  # the console has seen the node
            r = httpx.get(console.url + "api/node", params={"node": NODE}, timeout=5)
            if r.status_code == 200:
                break
            assert time.monotonic() < end, r.text
            time.sleep(0.1)
        body = json.dumps({"node": NODE, "values": {"robot.speed": 2.5}})
        r = httpx.post(
            console.url + "api/set", content=body, headers={"content-type": "application/json"}, timeout=20
        )
        assert r.status_code == 504, r.text
        assert r.json()["error"]["code"] == "OUTCOME_UNKNOWN"
        stalling.wait_stopped(1)
        values, revision = state_after_resume(dds, domain_id, stalling)
        assert values == START and revision == before
    finally:
        console.stop()


# -- a success is never reported failed; a refusal is never applied -----------------------------------


@pytest.mark.slow
def test_the_verdict_is_never_contradicted_by_the_node(domain_id: int, stalling: Stalling, dds: DDS) -> None:
    """Callbacks that take from well before to well after the deadline (timeout 1.5 s: deadline at
    1.35 s): a success is applied, an EXPIRED is not, and a late success still counts."""
    client = dds.client(domain_id)
    verdicts: dict[str, int] = {}
    for stall_ms in (200, 900, 1200, 1300, 1340, 1360, 1400, 1450, 1600, 1300, 1100):
        try:
            reply = client.set(NODE, {"robot.stall_ms": stall_ms}, timeout=1.5)
            verdict = "applied" if reply.successful else "refused"
        except ExpiredError:
            verdict = "expired"
        except OutcomeUnknownError:
            verdict = "unknown"
        verdicts[verdict] = verdicts.get(verdict, 0) + 1
        # read back once the node has decided (a get waits behind the set on the node's worker)
        now = client.get(NODE, ["robot.stall_ms"], timeout=10).results[0].value
        assert now is not None
        if verdict == "applied":
            assert now.to_python() == stall_ms
        elif verdict == "expired":
            assert now.to_python() != stall_ms
        if now.to_python() == stall_ms:  # set back to a value no trial uses, for the next trial
            client.set(NODE, {"robot.stall_ms": 0}, timeout=10)
    assert verdicts.get("applied", 0) >= 2 and verdicts.get("expired", 0) >= 1, verdicts


def test_a_request_past_its_deadline_is_refused_with_nothing_applied_and_no_event(
    domain_id: int, stalling: Stalling, dds: DDS
) -> None:
    participant = dds.participant(domain_id)
    client = dds.client(domain_id)
    before = client.get(NODE, list(START), timeout=10).revision
    peer = RawPeer(participant, count_events=True)
    late = wire.SetParametersRequest(
        node_id=NODE,
        client_id=77,
        request_id=1,
        expected_revision=-1,
        parameters=[wire.Parameter("robot.mode", wire.ParameterValue(type=4, string_value="manual"))],
        deadline=time.time_ns() - 1_000_000_000,  # a second ago
    )
    reply = peer.first_answer(late)
    assert reply.code == "EXPIRED" and "after its deadline" in reply.reason, reply
    peer.send(late)  # a resend gets the cached answer
    again = peer.replies(late, 2, timeout=10)[-1]
    assert again.code == "EXPIRED" and again.reason == reply.reason
    assert _value(client, "robot.mode") == "auto"
    time.sleep(0.5)
    assert [e for e in peer.pump_events() if e.name] == []  # no state sample: no event
    assert client.get(NODE, list(START), timeout=10).revision == before
    # the same request with time left is applied
    fresh = wire.SetParametersRequest(
        node_id=NODE,
        client_id=77,
        request_id=2,
        expected_revision=-1,
        parameters=late.parameters,
        deadline=time.time_ns() + 10_000_000_000,
    )
    applied = peer.first_answer(fresh)
    assert applied.code == "" and applied.results[0].successful
    assert _value(client, "robot.mode") == "manual"


def _value(client: Any, name: str) -> object:
    value = client.get(NODE, [name], timeout=10).results[0].value
    return None if value is None else value.to_python()
