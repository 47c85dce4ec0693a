"""Two hosts on one machine, joined by a veth pair, with 30 % of packets dropped on one side.

The server runs in one network namespace, the client (and later a monitor) in
the other, each with a Cyclone configuration bound to its own veth address,
unicast only, the other side as its peer (never ``--localhost``). nftables drops
30 % of the packets arriving in the client's namespace at random. Every request
must still complete correctly within its timeout (RELIABLE QoS retransmits), and
a monitor started afterwards must receive the node's whole state.

Needs root, iproute2 and nftables (``.ci/run`` installs them); skips with the
reason when namespaces cannot be created. Uses only 10.77.x.0/24 addresses inside
namespaces it creates (names carry the pid) and removes them in a finally.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from .conftest import PARAMDDS, Proc

NODE = "robot"
REQUESTS = 60
DROP_PERCENT = 30
PEER = str(Path(__file__).with_name("netns_peer.py"))


def _sh(*argv: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    return subprocess.run(list(argv), capture_output=True, text=True, timeout=30, check=check)


class Hosts:
    def __init__(self) -> None:
        tag = os.getpid() % 100_000
        self.subnet = f"10.77.{os.getpid() % 250}"
        self.ns = (f"pdsrv{tag}", f"pdcli{tag}")
        self.veth = (f"pdva{tag}", f"pdvb{tag}")
        self.addr = (f"{self.subnet}.1", f"{self.subnet}.2")

    def create(self) -> None:
        a, b = self.ns
        va, vb = self.veth
        _sh("ip", "netns", "add", a)
        _sh("ip", "netns", "add", b)
        _sh("ip", "link", "add", va, "type", "veth", "peer", "name", vb)
        _sh("ip", "link", "set", va, "netns", a)
        _sh("ip", "link", "set", vb, "netns", b)
        _sh("ip", "-n", a, "addr", "add", f"{self.addr[0]}/24", "dev", va)
        _sh("ip", "-n", b, "addr", "add", f"{self.addr[1]}/24", "dev", vb)
        for ns, dev in ((a, va), (b, vb)):
            _sh("ip", "-n", ns, "link", "set", "lo", "up")
            _sh("ip", "-n", ns, "link", "set", dev, "up")

    def drop_in_client(self, percent: int) -> None:
        b = self.ns[1]
        _sh("ip", "netns", "exec", b, "nft", "add", "table", "inet", "lossy")
        _sh(
            "ip", "netns", "exec", b, "nft", "add", "chain", "inet", "lossy", "in",
            "{ type filter hook input priority 0; }",
        )  # fmt: skip
        _sh(
            "ip", "netns", "exec", b, "nft", "add", "rule", "inet", "lossy", "in",
            "numgen", "random", "mod", "100", "<", str(percent), "counter", "drop",
        )  # fmt: skip

    def dropped(self) -> int:
        """Packets the loss rule has dropped so far."""
        out = _sh("ip", "netns", "exec", self.ns[1], "nft", "list", "table", "inet", "lossy").stdout
        words = out.split()
        return int(words[words.index("packets") + 1]) if "packets" in words else 0

    def destroy(self) -> None:
        for ns in self.ns:
            _sh("ip", "netns", "del", ns, check=False)  # takes its end of the veth pair with it

    def env(self, side: int, domain: int) -> dict[str, str]:
        me, other = self.addr[side], self.addr[1 - side]
        env = dict(os.environ)
        env.pop("PARAMDDS_LOCALHOST", None)  # --localhost would bind to 127.0.0.1
        env.update(
            PARAMDDS_DOMAIN=str(domain),
            PYTHONUNBUFFERED="1",
            CYCLONEDDS_URI=(
                '<CycloneDDS><Domain id="any"><General>'
                f'<Interfaces><NetworkInterface address="{me}"/></Interfaces>'
                "<AllowMulticast>false</AllowMulticast></General>"
                "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
                "<MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>"
                f'<Peers><Peer address="{other}"/></Peers></Discovery>'
                "</Domain></CycloneDDS>"
            ),
        )
        return env

    def exec(self, side: int, *argv: str) -> list[str]:
        return ["ip", "netns", "exec", self.ns[side], *argv]

    def serve(self, domain: int, node: str, params: Path, procs: list[Proc]) -> Proc:
        """A ``paramdds server`` for ``node`` on the server side, serving when this returns."""
        server = Proc(self.exec(0, PARAMDDS, "server", "-n", node, "-p", str(params)), self.env(0, domain))
        procs.append(server)
        server.wait_for("[SERVER] Serving node", timeout=20)
        return server

    def run_script(self, domain: int, script: str, *args: str, timeout: float) -> dict[str, Any]:
        """Run a Python script on the client side; the JSON object its last line prints."""
        run = subprocess.run(
            self.exec(1, sys.executable, script, *args),
            env=self.env(1, domain),
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        assert run.returncode == 0, run.stderr[-2000:]
        seen: dict[str, Any] = json.loads(run.stdout.strip().splitlines()[-1])
        return seen


def _why_not() -> str | None:
    if os.geteuid() != 0:
        return "network namespaces need root"
    for tool in ("ip", "nft"):
        if shutil.which(tool) is None:
            return f"{tool} is not installed (.ci/run installs iproute2 and nftables)"
    return None


@pytest.fixture
def hosts() -> Iterator[Hosts]:
    reason = _why_not()
    if reason:
        pytest.skip(reason)
    h = Hosts()
    h.destroy()  # a leftover of a killed earlier run with this pid
    try:
        try:
            h.create()
        except subprocess.CalledProcessError as exc:
            pytest.skip(f"cannot create network namespaces here: {exc.stderr.strip()}")
        yield h
    finally:
        h.destroy()


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_lossy_network_requests_complete_and_late_monitor_gets_full_state(
    hosts: Hosts, domain_id: int, params_file: Path, procs: list[Proc]
) -> None:
    hosts.drop_in_client(DROP_PERCENT)
    hosts.serve(domain_id, NODE, params_file, procs)
    seen = hosts.run_script(domain_id, PEER, NODE, str(REQUESTS), timeout=100)
    assert seen["errors"] == [], seen["errors"][:5]
    assert seen["slowest"] <= 5.0
    assert seen["monitor_complete"], seen
    values = seen["monitor_values"]
    assert set(values) == {
        "robot.max_velocity",
        "robot.name",
        "robot.enabled",
        "robot.wheel_count",
        "sensor.frame_ids",
    }
    assert values["robot.wheel_count"] == repr(seen["last"])
    assert values["robot.name"] == repr(f"n{seen['last'] - 1000}")
    assert hosts.dropped() > 20, "the loss rule dropped (almost) nothing: the test proved nothing"
    print(f"lossy network: discovery {seen['discovery']:.2f} s, slowest request {seen['slowest']:.2f} s")
