"""Network namespaces for the Zenoh tests: a "cloud" and sites linked only to it.

::

    root ns (the test: remote clients) --veth-- cloud ns (a router) --veth-- site ns k (DDS, servers, gateway)

Each site namespace runs its DDS on its own loopback only (``PARAMDDS_LOCALHOST=1``):
no DDS packet can leave it. The cloud namespace does not forward, so sites reach the
router and nothing else. Addresses are 10.78.<link>.0/24 inside namespaces made here;
names carry the pid; everything is removed in :meth:`Topology.destroy`. Loss is
nftables ``numgen random`` on a site's uplink interface, both directions.
"""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest

PORT = 7447


def sh(*argv: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    return subprocess.run(list(argv), capture_output=True, text=True, timeout=30, check=check)


def why_not() -> str | None:
    if os.geteuid() != 0:
        return "network namespaces need root"
    for tool in ("ip", "nft"):
        if shutil.which(tool) is None:
            return f"{tool} is not installed (.ci/run installs iproute2 and nftables)"
    return None


def skip_or_fail(reason: str) -> None:
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"CI=true but the Zenoh namespace tests cannot run: {reason}")
    pytest.skip(reason)


class Topology:
    def __init__(self, sites: list[str]) -> None:
        tag = os.getpid() % 100_000
        self.tag = tag
        self.cloud = f"pzc{tag}"
        self.sites = {s: f"pzs{k}_{tag}" for k, s in enumerate(sites)}
        self.base = 10 + os.getpid() % 200  # 10.78.<base + k>.0/24: link k
        self.links: dict[
            str, tuple[str, str, str, str]
        ] = {}  # site -> (cloud dev, site dev, cloud ip, site ip)
        self.front = (f"pzr{tag}", f"pzf{tag}", f"10.79.{self.base}.1", f"10.79.{self.base}.2")

    @property
    def router_endpoint(self) -> str:
        """Where the test (in the root namespace) reaches the router."""
        return f"tcp/{self.front[3]}:{PORT}"

    def uplink_endpoint(self, site: str) -> str:
        return f"tcp/{self.links[site][2]}:{PORT}"

    def create(self) -> None:
        sh("ip", "netns", "add", self.cloud)
        sh("ip", "netns", "exec", self.cloud, "ip", "link", "set", "lo", "up")
        root_dev, cloud_dev, root_ip, cloud_ip = self.front
        sh("ip", "link", "add", root_dev, "type", "veth", "peer", "name", cloud_dev)
        sh("ip", "link", "set", cloud_dev, "netns", self.cloud)
        sh("ip", "addr", "add", f"{root_ip}/24", "dev", root_dev)
        sh("ip", "link", "set", root_dev, "up")
        sh("ip", "-n", self.cloud, "addr", "add", f"{cloud_ip}/24", "dev", cloud_dev)
        sh("ip", "-n", self.cloud, "link", "set", cloud_dev, "up")
        for k, (site, ns) in enumerate(self.sites.items()):
            net = f"10.78.{self.base + k}"
            cdev, sdev = f"pzc{k}_{self.tag}", f"pzu{k}_{self.tag}"
            self.links[site] = (cdev, sdev, f"{net}.1", f"{net}.2")
            sh("ip", "netns", "add", ns)
            sh("ip", "-n", ns, "link", "set", "lo", "up")
            sh("ip", "link", "add", cdev, "type", "veth", "peer", "name", sdev)
            sh("ip", "link", "set", cdev, "netns", self.cloud)
            sh("ip", "link", "set", sdev, "netns", ns)
            sh("ip", "-n", self.cloud, "addr", "add", f"{net}.1/24", "dev", cdev)
            sh("ip", "-n", ns, "addr", "add", f"{net}.2/24", "dev", sdev)
            sh("ip", "-n", self.cloud, "link", "set", cdev, "up")
            sh("ip", "-n", ns, "link", "set", sdev, "up")

    def destroy(self) -> None:
        sh("ip", "link", "del", self.front[0], check=False)
        for ns in [*self.sites.values(), self.cloud]:
            sh("ip", "netns", "del", ns, check=False)

    def exec_in(self, site: str | None, *argv: str) -> list[str]:
        ns = self.cloud if site is None else self.sites[site]
        return ["ip", "netns", "exec", ns, *argv]

    def set_uplink(self, site: str, up: bool) -> None:
        sh("ip", "-n", self.sites[site], "link", "set", self.links[site][1], "up" if up else "down")

    def second_uplink(self, site: str) -> str:
        """Another address of the router on ``site``'s link (``.3``): a gateway dialling it can be
        cut alone (:meth:`cut_address`) while another gateway of the site keeps the uplink."""
        cdev, _sdev, cloud_ip, _site_ip = self.links[site]
        extra = cloud_ip.rsplit(".", 1)[0] + ".3"
        sh("ip", "-n", self.cloud, "addr", "add", f"{extra}/24", "dev", cdev)
        return f"tcp/{extra}:{PORT}"

    def cut_address(self, site: str, endpoint: str, cut: bool) -> None:
        """Drop (or stop dropping) every packet between ``site`` and the address of ``endpoint``."""
        ns, addr = self.sites[site], endpoint.split("/", 1)[1].rsplit(":", 1)[0]
        nft = ["ip", "netns", "exec", ns, "nft"]
        if not cut:
            sh(*nft, "delete", "table", "inet", "cut")
            return
        sh(*nft, "add", "table", "inet", "cut")
        for chain, hook, match in (("in", "input", "saddr"), ("out", "output", "daddr")):
            sh(*nft, "add", "chain", "inet", "cut", chain, f"{{ type filter hook {hook} priority 0; }}")
            sh(*nft, "add", "rule", "inet", "cut", chain, "ip", match, addr, "drop")

    def lossy_uplink(self, site: str, percent: int) -> None:
        ns, dev = self.sites[site], self.links[site][1]
        nft = ["ip", "netns", "exec", ns, "nft"]
        sh(*nft, "add", "table", "inet", "lossy")
        for chain, hook, match in (("in", "input", "iifname"), ("out", "output", "oifname")):
            sh(*nft, "add", "chain", "inet", "lossy", chain, f"{{ type filter hook {hook} priority 0; }}")
            sh(
                *nft, "add", "rule", "inet", "lossy", chain, match, dev,
                "numgen", "random", "mod", "100", "<", str(percent), "counter", "drop",
            )  # fmt: skip

    def dropped(self, site: str) -> int:
        out = sh("ip", "netns", "exec", self.sites[site], "nft", "list", "table", "inet", "lossy").stdout
        words = out.split()
        return sum(int(words[i + 1]) for i, w in enumerate(words) if w == "packets")
