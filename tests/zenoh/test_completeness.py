"""A remote answer says which sites it lacks: real router, gateways and CLI runs; the ledger's rules.

A fleet operator must never read a partial fleet as a whole one: a known site that did
not answer is a row, a line on stderr and exit 3, and ``dump`` reads the remote
monitor's state (no call per node) and writes what it holds.
"""

from __future__ import annotations

import json
import subprocess
from typing import Any

import pytest

from ..reliability.conftest import PARAMDDS, make_dds_env
from .conftest import Fleet

pytestmark = pytest.mark.timeout(90)


@pytest.mark.slow
def test_the_cli_names_the_sites_it_lacks_and_exits_3(fleet: Fleet) -> None:
    fleet.server("s1", "robot1", "robot2")
    fleet.gateway("s1")
    env = make_dds_env(fleet.domain("s1") + 1, PARAMDDS_ZENOH=fleet.endpoint)

    def run(*args: str, **extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [PARAMDDS, *args], env={**env, **extra}, capture_output=True, text=True, timeout=30
        )

    # every site known answered: exit 0, as before
    whole = run("nodes", "s1/*", "-o", "json")
    assert whole.returncode == 0, whole.stderr
    assert [r["node"] for r in json.loads(whole.stdout)] == ["s1/robot1", "s1/robot2"]

    # a site named whose uplink is down (no gateway): a row, a line on stderr, exit 3
    east = run("nodes", "east/*")
    assert east.returncode == 3, east
    assert "east/*" in east.stdout and "no answer" in east.stdout
    assert "lacks site 'east': no gateway of site 'east' is reachable" in east.stderr
    both = run("nodes", "s1/*", "east/*", "-o", "json")
    assert both.returncode == 3, both.stderr
    rows = json.loads(both.stdout)
    assert [r["node"] for r in rows] == ["s1/robot1", "s1/robot2", "east/*"]
    assert rows[-1]["online"] is False and "east" in rows[-1]["missing"]
    # the sites an operator names in PARAMDDS_ZENOH_SITES are known too
    named = run("nodes", "-o", "json", PARAMDDS_ZENOH_SITES="s1,east")
    assert named.returncode == 3, named.stderr
    assert [r["node"] for r in json.loads(named.stdout)] == ["s1/robot1", "s1/robot2", "east/*"]

    # dump: what is held is written, what is lacking is said, exit 3
    dumped = run("dump", "s1/*", "east/*")
    assert dumped.returncode == 3, dumped.stderr
    assert [line for line in dumped.stdout.splitlines() if not line[:1].isspace()] == [
        "/s1/robot1:",
        "/s1/robot2:",
    ]
    assert "lacks site 'east'" in dumped.stderr
    # get over a glob: every node's values from the monitor's state, and the sites lacking
    got = run("get", "s*/*", "robot.max_velocity", "nope", PARAMDDS_ZENOH_SITES="s1,east")
    assert got.returncode == 3, got.stderr
    assert got.stdout.splitlines() == [
        "s1/robot1: robot.max_velocity = double 1.5",
        "s1/robot2: robot.max_velocity = double 1.5",
    ]
    assert "nope: not found on 's1/robot1'" in got.stderr and "lacks site 'east'" in got.stderr
    whole_get = run("get", "s1/*", "robot.max_velocity", "-o", "json")
    assert whole_get.returncode == 0, whole_get.stderr
    assert json.loads(whole_get.stdout) == {
        "s1/robot1": {"robot.max_velocity": 1.5},
        "s1/robot2": {"robot.max_velocity": 1.5},
    }
    gone = run("dump", "s1/robot1", "s1/robot9")
    assert gone.returncode == 3 and "/s1/robot1:" in gone.stdout, gone
    assert "node 's1/robot9' is not present" in gone.stderr


@pytest.mark.slow
def test_dump_reads_the_monitors_state_never_a_call_per_node(fleet: Fleet) -> None:
    fleet.server("s1", "robot1", "robot2", "robot3")
    fleet.gateway("s1")
    calls: list[str] = []

    def count(query: Any) -> None:  # answers nothing: the gateway answers the calls
        calls.append(str(query.key_expr))

    watcher = fleet.remote()
    counters = [watcher.declare_queryable(f"paramdds/s1/node/*/{verb}", count) for verb in ("get", "list")]
    env = make_dds_env(fleet.domain("s1") + 1, PARAMDDS_ZENOH=fleet.endpoint)
    dumped = subprocess.run(
        [PARAMDDS, "dump", "--descriptors", "s1/*"], env=env, capture_output=True, text=True, timeout=30
    )
    assert dumped.returncode == 0, dumped.stderr
    assert dumped.stdout.count("max_velocity: 1.5") == 3, dumped.stdout
    assert "Top speed in m/s" in dumped.stdout  # the descriptors come with the state
    assert calls == []
    for counter in counters:
        counter.undeclare()
