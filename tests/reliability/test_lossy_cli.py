"""Fresh ``paramdds`` processes on a lossy link: a node that is there is never "not present".

Two network namespaces joined by a veth pair (``test_lossy_network.Hosts``); the
server in one, 30 % of the packets arriving in the other dropped at random. Each
pair is a fresh ``paramdds set`` then a fresh ``paramdds get`` of the same value
with ``--timeout 10``, so every process discovers the server from nothing, over the
lossy link. Zero "not present", zero wrong values, zero timeouts: every command
succeeds. (Until issue 24 the test allowed 2 processes in 200 that ended in TIMEOUT
with "no parameter server discovered yet": the server's four answers to a newcomer
were all lost, and because the process already knew the other CLI processes beside
it, it never asked again; it now does, see :mod:`paramdds.dds.discovery`.)

Concurrency: :data:`LANES` pairs run at once, each lane on a parameter of its own
(so a lane's get can only see its own set). Concurrent processes do not help each
other discover: each process has its own participant, its own sockets, and peers
answer each one separately. What concurrency distorts is CPU time: start-up and
discovery run slower, which stretches the printed times and, if anything, makes a
false "not present" more likely (a harder test, not an easier one). Four lanes take
the test from about 200 s (one at a time) to well under half that on an idle machine.

Needs root, iproute2 and nftables (``.ci/run`` installs them); skips with the
reason when namespaces cannot be created.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from . import test_lossy_network as lossy
from .conftest import PARAMDDS, Proc
from .test_lossy_network import DROP_PERCENT, Hosts

lossy_hosts = lossy.hosts  # that module's fixture, here by this name: two namespaces, removed at the end

NODE = "far"
API_ROUNDS = 30
FRESH_CLIENTS = str(Path(__file__).with_name("netns_fresh_clients.py"))
PAIRS = 100
LANES = 4
TIMEOUT = "10"


def _params(lanes: int) -> str:
    lines = ["parameters:"]
    for lane in range(lanes):
        lines += [f'  - name: "lane{lane}"', '    type: "integer"', "    value: 0"]
    return "\n".join(lines) + "\n"


def _run(net: Hosts, domain: int, *args: str) -> tuple[float, subprocess.CompletedProcess[str]]:
    started = time.monotonic()
    done = subprocess.run(
        net.exec(1, PARAMDDS, *args, "--timeout", TIMEOUT, "-o", "json"),
        env=net.env(1, domain),
        capture_output=True,
        text=True,
        timeout=30,
    )
    return time.monotonic() - started, done


def _lane(pair: Callable[[int], None], lane: int) -> None:
    for k in range(lane, PAIRS, LANES):
        pair(k)


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


@pytest.mark.slow
@pytest.mark.timeout(420)
def test_fresh_cli_pairs_on_a_lossy_link_never_report_a_present_node_absent(
    lossy_hosts: Hosts, domain_id: int, tmp_path: Path, procs: list[Proc]
) -> None:
    hosts = lossy_hosts
    params = tmp_path / "lanes.yaml"
    params.write_text(_params(LANES))
    hosts.drop_in_client(DROP_PERCENT)
    hosts.serve(domain_id, NODE, params, procs)

    failures: list[str] = []
    times: list[float] = []

    def pair(k: int) -> None:
        name, value = f"lane{k % LANES}", 1000 + k
        took, done = _run(hosts, domain_id, "set", NODE, f"{name}={value}")
        times.append(took)
        if done.returncode != 0:
            failures.append(f"set {k}: exit {done.returncode}: {done.stderr.strip()[-300:]}")
            return
        took, done = _run(hosts, domain_id, "get", NODE, name)
        times.append(took)
        if done.returncode != 0:
            failures.append(f"get {k}: exit {done.returncode}: {done.stderr.strip()[-300:]}")
        elif json.loads(done.stdout) != {name: value}:
            failures.append(f"get {k}: {done.stdout.strip()} != {value}")

    with ThreadPoolExecutor(LANES) as pool:
        # lane k % LANES runs its pairs in order: a lane's get follows its own set
        lanes = [pool.submit(_lane, pair, lane) for lane in range(LANES)]
        for lane in lanes:
            lane.result()

    assert hosts.dropped() > 100, "the loss rule dropped (almost) nothing: the test proved nothing"
    absent = [f for f in failures if "not present" in f]
    assert absent == [], absent[:5]
    assert failures == [], failures[:5]
    assert len(times) == 2 * PAIRS
    print(
        f"lossy CLI: {len(times)} processes, none failed; "
        "whole-process seconds: "
        f"median {statistics.median(times):.2f}, p90 {_percentile(times, 0.9):.2f}, "
        f"p99 {_percentile(times, 0.99):.2f}, max {max(times):.2f}"
    )


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_fresh_api_clients_on_a_lossy_link_never_report_a_present_node_absent(
    lossy_hosts: Hosts, domain_id: int, params_file: Path, procs: list[Proc]
) -> None:
    """The API's presence rule and ``wait_for_node``: a new participant and client per round."""
    hosts = lossy_hosts
    hosts.drop_in_client(DROP_PERCENT)
    hosts.serve(domain_id, NODE, params_file, procs)
    args = (NODE, "robot.wheel_count", "4", str(API_ROUNDS))
    seen = hosts.run_script(domain_id, FRESH_CLIENTS, *args, timeout=280)
    assert hosts.dropped() > 50, "the loss rule dropped (almost) nothing: the test proved nothing"
    assert seen["errors"] == [], seen["errors"][:5]
    assert len(seen["seconds"]) == API_ROUNDS
    times = seen["seconds"]
    print(
        f"lossy API: {API_ROUNDS} fresh clients, seconds: median {statistics.median(times):.2f}, "
        f"max {max(times):.2f}"
    )
