"""``server --persist`` keeps its nodes' history: killed with SIGKILL and restarted, a server
answers ``history`` with every change it had acknowledged (who, via, old, new, refusals
too) and each parameter's blame, and its records go on counting from there."""

from __future__ import annotations

import json
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.history import HistoryRecord
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import close_participant, make_participant

from ._support import next_domain, run_cli, start_server

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]
NODE = "robot1"


@pytest.fixture
def domain() -> int:
    return next_domain()


class _Clients:
    """Python clients of one participant, each claiming a name; closed before the participant."""

    def __init__(self, domain: int) -> None:
        self.dp = make_participant(domain, localhost=True, app_name="paramdds-test-client")
        self.made: dict[str, ParameterClient] = {}

    def __call__(self, name: str) -> ParameterClient:
        if name not in self.made:
            self.made[name] = ParameterClient(self.dp, as_=name)
        return self.made[name]

    def close(self) -> None:
        for client in self.made.values():
            client.close()
        close_participant(self.dp)


@pytest.fixture
def client_as(domain: int) -> Iterator[_Clients]:
    clients = _Clients(domain)
    yield clients
    clients.close()


def _history(client: ParameterClient) -> list[HistoryRecord]:
    return list(client.history(NODE, timeout=10).records)


def _blame(client: ParameterClient, *names: str) -> dict[str, tuple[str, str]]:
    got = client.get(NODE, list(names), with_descriptors=True, timeout=10)
    return {r.name: (r.last_change.who, r.last_change.via) for r in got.results if r.last_change is not None}


def test_history_and_blame_survive_kill_9(
    params_file: Path, tmp_path: Path, domain: int, client_as: _Clients
) -> None:
    state = tmp_path / "state.yaml"
    args = ("-n", NODE, "-p", str(params_file), "--persist", str(state))
    server = start_server(domain, *args)
    bob = client_as("bob")
    try:
        out = run_cli(domain, "--as", "alice", "set", NODE, "robot.max_velocity=2.5")
        assert out.returncode == 0, out.stderr
        assert bob.set(NODE, {"robot.name": "bobbot"}, timeout=10).results[0].successful
        refused = bob.set(NODE, {"robot.wheel_count": "four"}, timeout=10)  # a string for an integer
        assert not refused.results[0].successful
        out = run_cli(domain, "--as", "carol", "set", NODE, "robot.max_velocity=3.0", "sensor.rate_hz=60")
        assert out.returncode == 0, out.stderr
        before = _history(bob)
    finally:
        server.stop(signal.SIGKILL)  # every reply above came after its write reached the disk
    mine = [(r.name, r.who, r.via, _v(r.old), _v(r.new), r.applied) for r in before if r.via != "start"]
    assert mine == [
        ("robot.max_velocity", "alice", "cli", 1.5, 2.5, True),
        ("robot.name", "bob", "api", "my_robot", "bobbot", True),
        ("robot.wheel_count", "bob", "api", 4, "four", False),
        ("robot.max_velocity", "carol", "cli", 2.5, 3.0, True),
        ("sensor.rate_hz", "carol", "cli", 30, 60, True),
    ]
    assert {r.via for r in before} == {"start", "cli", "api"}  # the start values are there too

    server = start_server(domain, *args)
    try:
        assert _history(bob) == before  # every record, with its seq, nothing added by the restart
        out = run_cli(domain, "history", NODE, "robot.max_velocity", "-o", "json")  # the verb says the same
        assert out.returncode == 0, out.stderr
        printed = [r for r in json.loads(out.stdout) if r["via"] != "start"]
        rows = [(r["who"], r["via"], r["old"], r["new"]) for r in printed]
        assert rows == [("alice", "cli", 1.5, 2.5), ("carol", "cli", 2.5, 3.0)]
        assert _blame(bob, "robot.max_velocity", "robot.name", "sensor.rate_hz", "robot.wheel_count") == {
            "robot.max_velocity": ("carol", "cli"),
            "robot.name": ("bob", "api"),
            "sensor.rate_hz": ("carol", "cli"),
            "robot.wheel_count": before[0].who and _start_blame(before, "robot.wheel_count"),
        }
        eve = client_as("eve")
        assert not eve.set(NODE, {"robot.enabled": 3}, timeout=10).results[0].successful  # refused only
    finally:
        server.stop(signal.SIGKILL)  # right after a reply that changed nothing: the refusal is kept
    server = start_server(domain, *args)
    try:
        after = _history(bob)
        assert after[: len(before)] == before
        (new,) = after[len(before) :]
        assert (new.name, new.who, new.applied) == ("robot.enabled", "eve", False)
        assert new.seq == before[-1].seq + 1
        assert bob.set(NODE, {"robot.name": "again"}, timeout=10).results[0].successful
        assert _history(bob)[-1].seq == new.seq + 1  # the count goes on
    finally:
        assert server.stop() == 0


def _v(value: Any) -> Any:
    return None if value is None else value.value


def _start_blame(records: list[HistoryRecord], name: str) -> tuple[str, str]:
    (start,) = [r for r in records if r.name == name and r.applied]
    return (start.who, start.via)
