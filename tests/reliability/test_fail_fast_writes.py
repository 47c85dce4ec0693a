"""A write to a node no server announced fails fast as "not present", and never lands later.

Real processes and real Cyclone on loopback. The rule (``paramdds.core.call``): a server
takes a request only for a node it hosts and announces that node before it takes any;
requests are VOLATILE. So once discovery is settled and sure, a write whose node no
server announced is held (no copy sent, not even to a server that matches later) and,
its last copy half a second old, fails UNAVAILABLE: exit 3, as a ``get`` does, instead
of waiting its whole timeout for OUTCOME_UNKNOWN (exit 5).
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from paramdds.core.table import ParameterTable
from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import close_participant, make_participant
from paramdds.errors import UnavailableError

from .conftest import DDS, PARAMDDS, Proc, make_dds_env, start_server, wait


def cli(domain: int, *args: str) -> tuple[float, subprocess.CompletedProcess[str]]:
    started = time.monotonic()
    done = subprocess.run(
        [PARAMDDS, *args], env=make_dds_env(domain), capture_output=True, text=True, timeout=60
    )
    return time.monotonic() - started, done


@pytest.mark.slow
def test_a_set_after_kill_9_of_the_node_is_not_present_as_fast_as_a_get(
    domain_id: int, procs: list[Proc], params_file: Path
) -> None:
    procs.append(start_server(domain_id, "-n", "bystander"))  # a system that goes on without it
    victim = start_server(domain_id, "-n", "victim", "-p", str(params_file))
    procs.append(victim)
    took, done = cli(domain_id, "set", "victim", "robot.max_velocity=2.0", "--timeout", "10")
    assert done.returncode == 0, done.stderr  # positive control: the same write, while it is there
    victim.kill()
    get_took, got = cli(domain_id, "get", "victim", "robot.max_velocity", "--timeout", "10")
    assert got.returncode == 3 and "not present" in got.stderr, got.stderr
    took, done = cli(domain_id, "set", "victim", "robot.max_velocity=3.0", "--timeout", "10")
    assert done.returncode == 3, (done.returncode, done.stderr)  # not 5: it cannot have landed
    assert "node 'victim' is not present" in done.stderr and "sent no more" in done.stderr
    # about get's time plus the half second a held write waits for its last copy; far from 10 s
    assert took < get_took + 2.0 and took < 5.0, (took, get_took)


def fresh_set(domain: int, node: str) -> tuple[float, UnavailableError]:
    """A set from a fresh client (discovery not settled, so it is sent): its time and error."""
    participant = make_participant(domain, localhost=True, app_name="fail-fast")
    try:
        with ParameterClient(participant) as client:
            started = time.monotonic()
            with pytest.raises(UnavailableError) as raised:
                client.set(node, {"speed": 2.5}, timeout=10)
            took = time.monotonic() - started
            with pytest.raises(UnavailableError):  # known absent now: the next write is not even sent
                client.set(node, {"speed": 2.5}, timeout=10)
            return took, raised.value
    finally:
        close_participant(participant)


@pytest.mark.slow
def test_a_node_hosted_right_after_a_set_gave_up_never_applies_it(
    domain_id: int, dds: DDS, procs: list[Proc]
) -> None:
    procs.append(start_server(domain_id, "-n", "bystander"))
    # a running server whose request reader takes (and drops) the copies, as every server does
    server = dds.server(domain_id, ParameterTable("other"))
    took, error = fresh_set(domain_id, "ghost")
    assert "not present" in str(error) and took < 5.0, (took, error)
    # right after the client gave up, the running server hosts the node
    ghost = ParameterTable("ghost")
    ghost.declare("speed", 1.0)
    before = ghost.revision
    server.add_node(ghost)
    # and a new process hosts another node a client gave up on the same way
    took, error = fresh_set(domain_id, "late")
    assert "not present" in str(error) and took < 5.0, (took, error)
    procs.append(start_server(domain_id, "-n", "late", "--allow-undeclared"))
    time.sleep(1.5)  # a copy still on its way, or sent again, would be applied by now
    assert ghost.get("speed").value == 1.0 and ghost.revision == before, "a write reported failed landed"
    client = dds.client(domain_id)
    assert wait(lambda: client.presence("late").value == "online", 10.0)
    reply = client.get("late", ["speed"], timeout=10)
    assert reply.results[0].value is None, "a write reported failed landed on a node started later"
