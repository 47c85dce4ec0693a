"""``paramdds bench zenoh``: sites behind Zenoh gateways against one stretched DDS domain.

For each site count S (``--sites``, default 1,10): S server processes of N nodes x P
parameters (``--nodes``, default 100; ``--params``, 20), each on a DDS domain of its own
with a ``paramdds zenoh`` gateway, and a Zenoh router session in this process, all on
loopback. Site 0's gateway reaches the router through a byte-counting TCP relay: its
uplink. Measured:

* **fresh remote client holds every node**: a new Zenoh session and
  :class:`~paramdds.zenoh.monitor.RemoteParameterMonitor` until every node of every site
  is complete (median of ``--rounds``, default 3);
* **remote get / set p50, p99** of a node of site 0 (``--requests``, default 300) and the
  same calls made directly on site 0's DDS domain (a ParameterClient there);
* **uplink bytes per change** with 1 and with 10 remote viewers: changes made on site 0
  by a DDS client there, one every :data:`PACE` s, bytes the gateway sent up, divided by
  the changes (the least of three windows), and the uplink's bytes per second with no
  change (10 viewers; part of each window);
* the **baseline**: the same S x N nodes on *one* DDS domain (what a fleet without
  Zenoh would stretch over its sites), a fresh DDS monitor until every node is
  complete (median of the rounds); and, run as root, its **bytes on site 0's uplink per
  change** with 1 and 10 viewers: site 0's server in a network namespace of its own,
  linked by a veth pair to the rest (the other sites' servers, the viewers: ``monitor``
  worker processes), Cyclone unicast only with the two ends as peers (what a WAN
  needs), the changes made in site 0's server process; counted as UDP payload (the
  veth's bytes less 42 B of headers per packet) as the relay counts TCP payload.

States that a remote monitor here refused as not decoding (asked for again) are counted
and, if any, told under the table.

Everything runs on one machine: there is no WAN round trip in these figures.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

from ._common import Workers, emit, median, node_names, note, percentile, render

ROUNDS = 3
VIEWERS = 10
CHANGES = 50


class Relay:
    """A TCP relay 127.0.0.1:port -> target that counts the bytes each way (an uplink)."""

    def __init__(self, target: tuple[str, int]) -> None:
        self.target = target
        self.up = 0  # client -> target
        self.down = 0
        self._lock = threading.Lock()
        self._sock = socket.socket()
        self._sock.bind(("127.0.0.1", 0))
        self._sock.listen(8)
        self.port = int(self._sock.getsockname()[1])
        self._closed = False
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while not self._closed:
            try:
                conn, _ = self._sock.accept()
            except OSError:
                return
            try:
                upstream = socket.create_connection(self.target, timeout=5)
            except OSError:
                conn.close()
                continue
            upstream.settimeout(None)
            for sock in (conn, upstream):  # as Zenoh's own links: no Nagle delay on small messages
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            threading.Thread(target=self._pump, args=(conn, upstream, True), daemon=True).start()
            threading.Thread(target=self._pump, args=(upstream, conn, False), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket, up: bool) -> None:
        try:
            while True:
                data = src.recv(65536)
                if not data:
                    break
                with self._lock:
                    if up:
                        self.up += len(data)
                    else:
                        self.down += len(data)
                dst.sendall(data)
        except OSError:
            pass
        finally:
            with contextlib.suppress(OSError):
                dst.shutdown(socket.SHUT_WR)

    def sent_up(self) -> int:
        with self._lock:
            return self.up

    def close(self) -> None:
        self._closed = True
        self._sock.close()


HEADERS = 42  # bytes of Ethernet (14), IPv4 (20) and UDP (8) headers in each packet on the veth


def why_no_uplink() -> str | None:
    """Why the stretched domain's uplink cannot be counted here (None: it can)."""
    import os
    import shutil

    if os.geteuid() != 0:
        return "needs root: site 0 runs in a network namespace of its own"
    if shutil.which("ip") is None:
        return "needs iproute2 (ip)"
    return None


class SiteNamespace:
    """Site 0 of the stretched DDS domain in a network namespace of its own, linked to this
    one (the rest of the fleet, the viewers) by a veth pair: its uplink, whose bytes are
    counted on this side. Cyclone runs unicast only on it, with the two ends as peers."""

    def __init__(self) -> None:
        import os

        tag = os.getpid() % 100_000
        self.ns, self.here, self.there = f"pzb{tag}", f"pzbh{tag}", f"pzbt{tag}"
        net = f"10.77.{10 + os.getpid() % 200}"
        self.here_ip, self.there_ip = f"{net}.1", f"{net}.2"

    @staticmethod
    def _ip(*argv: str, check: bool = True) -> None:
        import subprocess

        subprocess.run(["ip", *argv], check=check, capture_output=True, text=True, timeout=30)

    def __enter__(self) -> SiteNamespace:
        self._ip("netns", "del", self.ns, check=False)  # a killed earlier run's
        self._ip("netns", "add", self.ns)
        self._ip("-n", self.ns, "link", "set", "lo", "up")
        self._ip("link", "add", self.here, "type", "veth", "peer", "name", self.there)
        self._ip("link", "set", self.there, "netns", self.ns)
        self._ip("addr", "add", f"{self.here_ip}/24", "dev", self.here)
        self._ip("-n", self.ns, "addr", "add", f"{self.there_ip}/24", "dev", self.there)
        self._ip("link", "set", self.here, "up")
        self._ip("-n", self.ns, "link", "set", self.there, "up")
        return self

    def __exit__(self, *exc: object) -> None:
        self._ip("link", "del", self.here, check=False)
        self._ip("netns", "del", self.ns, check=False)

    def wrap(self) -> list[str]:
        return ["ip", "netns", "exec", self.ns]

    def env(self, *, inside: bool, participants: int) -> dict[str, str]:
        """A worker's environment: Cyclone on this end of the link, unicast, both ends as peers."""
        import os

        device = self.there if inside else self.here
        peers = "".join(f'<Peer address="{a}"/>' for a in (self.here_ip, self.there_ip))
        uri = (
            f'<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="{device}"/>'
            "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
            f"<Peers>{peers}</Peers><ParticipantIndex>auto</ParticipantIndex>"
            f"<MaxAutoParticipantIndex>{participants}</MaxAutoParticipantIndex></Discovery></Domain></CycloneDDS>"
        )
        env = {k: v for k, v in os.environ.items() if k != "PARAMDDS_LOCALHOST"}
        return {**env, "CYCLONEDDS_URI": uri, "PYTHONUNBUFFERED": "1"}

    def payload_up(self) -> int:
        """UDP payload bytes site 0 has sent up the link (received on this end)."""
        stats = f"/sys/class/net/{self.here}/statistics/"
        with open(stats + "rx_bytes") as b, open(stats + "rx_packets") as p:
            return int(b.read()) - HEADERS * int(p.read())


def _dds_uplink(
    s: int, nodes: int, params: int, changes: int, domain: int, changed: tuple[str, str], timeout: float
) -> dict[str, float]:
    """The stretched domain's bytes on site 0's uplink per change, with 1 and 10 DDS viewers."""
    node, pname = changed
    out: dict[str, float] = {}
    participants = s + VIEWERS + 8
    with SiteNamespace() as link, Workers(localhost=False, domain=domain) as workers:
        inside, outside = (
            link.env(inside=True, participants=participants),
            link.env(inside=False, participants=participants),
        )
        size = ["--nodes", str(nodes), "--params", str(params)]
        site0 = workers.start("server", *size, "--changes", wrap=link.wrap(), env=inside)
        others = [
            workers.start("server", *size, "--offset", str(k * nodes), env=outside) for k in range(1, s)
        ]
        for w in [site0, *others]:
            w.read("READY", timeout)

        def change(i: int) -> None:
            site0.send(f"{node} {pname} {float(i) + 0.5}")
            if not site0.read("CHANGED", 10.0)["ok"]:
                raise RuntimeError(f"the bench's change of {node} {pname} was refused")

        viewer = ["--nodes", str(s * nodes), "--timeout", str(timeout), "--stay"]
        viewers = [workers.start("monitor", *viewer, env=outside)]
        viewers[0].read("RESULT", timeout)
        out["dds_uplink_bytes_per_change_1"] = _bytes_per_change(link.payload_up, change, changes)
        viewers += [workers.start("monitor", *viewer, env=outside) for _ in range(VIEWERS - 1)]
        for v in viewers[1:]:
            v.read("RESULT", timeout)
        out["dds_uplink_bytes_per_change_10"] = _bytes_per_change(link.payload_up, change, changes)
        out["dds_uplink_idle_bytes_per_s_10"] = _idle_rate(link.payload_up)
    return out


class _NotDecoded(logging.Handler):
    """Counts the states this process's remote monitors refused as not decoding (their
    warning starts "ignoring a state"): payloads with Zenoh's framing spliced in, docs/zenoh.md."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.count = 0

    def emit(self, record: logging.LogRecord) -> None:
        message = record.getMessage()
        note(message)  # as Python's last-resort handler would have shown it
        if message.startswith("ignoring a state"):
            self.count += 1


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def _gateways(sites: list[tuple[str, int]], endpoints: list[str]) -> Iterator[list[Any]]:
    import os
    import subprocess
    import sys

    procs = []
    try:
        for (site, domain), endpoint in zip(sites, endpoints, strict=True):
            env = dict(os.environ, PARAMDDS_DOMAIN=str(domain), PARAMDDS_LOCALHOST="1", PYTHONUNBUFFERED="1")
            cmd = [sys.executable, "-m", "paramdds.cli", "zenoh", "--site", site, "--connect", endpoint]
            proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            procs.append(proc)
        for proc in procs:
            assert proc.stdout is not None
            line = proc.stdout.readline()
            if "[ZENOH] Gateway" not in line:
                raise RuntimeError(
                    f"a gateway did not start: {line!r} {proc.stderr.read() if proc.stderr else ''}"
                )
        yield procs
    finally:
        for proc in procs:
            proc.terminate()
        for proc in procs:
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(10)
            if proc.poll() is None:
                proc.kill()


def _remote_full_state(endpoint: str, names: list[str], timeout: float) -> float:
    from ..zenoh.config import ZenohOptions, open_session
    from ..zenoh.monitor import RemoteParameterMonitor

    t0 = time.perf_counter()
    session = open_session(ZenohOptions(connect=[endpoint]))
    try:
        monitor = RemoteParameterMonitor(session, timeout=timeout)
        try:
            _hold([monitor], names, timeout)
            return time.perf_counter() - t0
        finally:
            monitor.close()
    finally:
        session.close()


def _dds_full_state(domain: int, names: list[str], timeout: float) -> float:
    from ..dds.monitor import ParameterMonitor
    from ..dds.participant import close_participant, make_participant

    t0 = time.perf_counter()
    dp = make_participant(domain, localhost=True, app_name="bench-zenoh")
    monitor = ParameterMonitor(dp)
    ok = monitor.wait_complete(names, timeout)
    took = time.perf_counter() - t0
    monitor.close()
    close_participant(dp)
    if not ok:
        raise RuntimeError(f"a fresh DDS monitor did not hold all {len(names)} nodes within {timeout} s")
    return took


def _hold(viewers: list[Any], names: list[str], timeout: float) -> None:
    """Wait until every remote viewer holds every node; RuntimeError naming what one lacks."""
    for v in viewers:
        if not v.wait_complete(names, timeout):
            snap = v.snapshot()
            lacking = [n for n in names if n not in snap or not snap[n].complete]
            shown = ", ".join(
                f"{n} ({len(snap[n].parameters)} of {snap[n].announced} parameters, "
                f"{'online' if snap[n].online else 'offline'})"
                if n in snap
                else f"{n} (never seen)"
                for n in lacking[:3]
            )
            raise RuntimeError(
                f"a remote viewer lacked {len(lacking)} of {len(names)} nodes after {timeout:g} s: {shown}"
            )


def _latencies(call: Any, count: int) -> tuple[float, float]:
    times = []
    for i in range(count):
        t0 = time.perf_counter()
        call(i)
        times.append((time.perf_counter() - t0) * 1000)
    return percentile(times, 50), percentile(times, 99)


PACE = 0.05  # seconds between two changes: more than the gateway's BATCH, so each is published alone


IDLE = 2.0  # seconds the idle uplink is counted


def _idle_rate(count: Callable[[], int]) -> float:
    """Bytes per second on an uplink with no change (keepalives; for DDS also discovery,
    heartbeats and acknowledgements): part of every window :func:`_bytes_per_change` counts."""
    before = count()
    time.sleep(IDLE)
    return (count() - before) / IDLE


def _bytes_per_change(count: Callable[[], int], change: Callable[[int], object], changes: int) -> float:
    """Bytes counted per change, the least of three windows (other traffic on the machine only adds)."""
    best = float("inf")
    step = max(1, changes // 3)
    for w in range(3):
        time.sleep(0.3)
        before = count()
        for i in range(step):
            change(w * step + i)
            time.sleep(PACE)
        time.sleep(0.5)
        best = min(best, (count() - before) / step)
    return best


def _double_param(client: Any, node: str) -> str:
    """A double parameter of ``node`` that takes 0..100 (the bench's tables have some)."""
    names = list(client.list(node).names)
    reply = client.get(node, names, with_descriptors=True)
    for r in reply.results:
        d = r.descriptor
        if r.value is not None and r.value.type.label == "double" and d is not None:
            fr = d.floating_point_range
            if (
                not d.read_only
                and not d.validators
                and (fr is None or (fr.from_value <= 0 and fr.to_value >= 100))
            ):
                return str(r.name)
    raise RuntimeError(f"node {node!r} has no unconstrained double parameter to change")


def _measure(
    s: int, nodes: int, params: int, requests: int, rounds: int, changes: int, base_domain: int
) -> dict[str, Any]:
    from ..dds.client import ParameterClient
    from ..dds.participant import close_participant, make_participant
    from ..zenoh.client import RemoteParameterClient
    from ..zenoh.config import ZenohOptions, open_session, router_options
    from ..zenoh.monitor import RemoteParameterMonitor

    timeout = 60.0
    names = node_names(nodes)
    note(f"{s} site(s) x {nodes} nodes x {params} params")
    domains = [(base_domain + k) % 230 or 1 for k in range(s)]
    sites = [(f"site{k}", domains[k]) for k in range(s)]
    port = _free_port()
    router = open_session(router_options([f"tcp/127.0.0.1:{port}"]))
    relay = Relay(("127.0.0.1", port))
    endpoint = f"tcp/127.0.0.1:{port}"
    run: dict[str, Any] = {"sites": s}
    uplink_skip = why_no_uplink()
    not_decoded = _NotDecoded()
    logging.getLogger("paramdds.zenoh").addHandler(not_decoded)
    try:
        with Workers(localhost=True, domain=domains[0]) as workers:
            servers = [
                workers.start("server", "--nodes", str(nodes), "--params", str(params), domain=d)
                for _, d in sites
            ]
            for w in servers:
                w.read("READY", timeout)
            uplinks = [f"tcp/127.0.0.1:{relay.port}"] + [endpoint] * (s - 1)
            with _gateways(sites, uplinks):
                everyone = [f"{site}/{n}" for site, _ in sites for n in names]
                run["remote_full_state_s"] = median(
                    [_remote_full_state(endpoint, everyone, timeout) for _ in range(rounds)]
                )
                dp = make_participant(domains[0], localhost=True, app_name="bench-zenoh")
                direct = ParameterClient(dp, timeout=10.0)
                direct.wait_for_node(names[0], 10.0)
                session = open_session(ZenohOptions(connect=[endpoint]))
                remote = RemoteParameterClient(session, timeout=10.0)
                target, remote_target = names[0], f"site0/{names[0]}"
                pname = _double_param(direct, target)
                value = direct.get_value(target, pname)
                run["remote_get_ms"] = _latencies(lambda _i: remote.get(remote_target, [pname]), requests)
                run["dds_get_ms"] = _latencies(lambda _i: direct.get(target, [pname]), requests)
                run["remote_set_ms"] = _latencies(
                    lambda _i: remote.set(remote_target, {pname: value}), requests
                )
                run["dds_set_ms"] = _latencies(lambda _i: direct.set(target, {pname: value}), requests)
                changed = names[-1]
                cname = _double_param(direct, changed)
                run["changed"] = [changed, cname]

                def change(i: int) -> None:
                    if not direct.set(changed, {cname: float(i) + 0.5}).successful:
                        raise RuntimeError(f"the bench's change of {changed} {cname} was refused")

                # viewers of site 0 (what its uplink carries to): each of the whole fleet, in this
                # process with the router, took 27 s for 10 x 1,000 nodes and starved the routing
                viewers: list[Any] = []
                site0 = [f"site0/{n}" for n in names]
                sessions: list[Any] = [open_session(ZenohOptions(connect=[endpoint]))]
                viewers.append(RemoteParameterMonitor(sessions[0], sites=["site0"], timeout=timeout))
                _hold(viewers[:1], site0, timeout)
                run["uplink_bytes_per_change_1"] = _bytes_per_change(relay.sent_up, change, changes)
                for _ in range(VIEWERS - 1):
                    sessions.append(open_session(ZenohOptions(connect=[endpoint])))
                    viewers.append(RemoteParameterMonitor(sessions[-1], sites=["site0"], timeout=timeout))
                _hold(viewers, site0, timeout)  # their first state queries must not count as changes
                run["uplink_bytes_per_change_10"] = _bytes_per_change(relay.sent_up, change, changes)
                run["uplink_idle_bytes_per_s_10"] = _idle_rate(relay.sent_up)
                for v in viewers:
                    v.close()
                for z in sessions:
                    z.close()
                session.close()
                direct.close()
                close_participant(dp)
        # the baseline: the same fleet as one stretched DDS domain
        with Workers(localhost=True, domain=domains[0]) as workers:
            servers = [
                workers.start(
                    "server", "--nodes", str(nodes), "--offset", str(k * nodes), "--params", str(params)
                )
                for k in range(s)
            ]
            for w in servers:
                w.read("READY", timeout)
            all_names = node_names(s * nodes)
            run["dds_full_state_s"] = median(
                [_dds_full_state(domains[0], all_names, timeout) for _ in range(rounds)]
            )
        # its bytes on site 0's uplink, with site 0 in a network namespace (root only)
        run["dds_uplink_bytes_per_change_1"] = run["dds_uplink_bytes_per_change_10"] = None
        run["dds_uplink_idle_bytes_per_s_10"] = None
        run["dds_uplink_not_measured"] = uplink_skip
        if uplink_skip is None:
            changed_at = (run["changed"][0], run["changed"][1])
            run.update(_dds_uplink(s, nodes, params, changes, domains[0], changed_at, timeout))
    finally:
        relay.close()
        router.close()
        logging.getLogger("paramdds.zenoh").removeHandler(not_decoded)
    run["states_not_decoded"] = not_decoded.count
    return run


def run(args: argparse.Namespace) -> int:
    quick = bool(getattr(args, "quick", False))
    site_counts: list[int] = getattr(args, "sites", None) or ([1, 2] if quick else [1, 10])
    nodes = (args.nodes or [20 if quick else 100])[0]
    params = args.params or 20
    requests = args.requests or (50 if quick else 300)
    rounds = args.rounds or (1 if quick else ROUNDS)
    changes = 10 if quick else CHANGES
    base_domain = args.domain if args.domain is not None else 1
    rows: list[list[object]] = []
    data: dict[str, Any] = {"nodes_per_site": nodes, "params": params, "runs": []}
    for r, s in enumerate(site_counts):  # each run on domains of its own (Cyclone keeps a closed one's)
        run = _measure(s, nodes, params, requests, rounds, changes, base_domain + r * (max(site_counts) + 1))
        data["runs"].append(run)
        g, dg = run["remote_get_ms"], run["dds_get_ms"]
        st, ds = run["remote_set_ms"], run["dds_set_ms"]
        rows.append(
            [
                s,
                s * nodes,
                round(run["remote_full_state_s"] * 1000),
                round(run["dds_full_state_s"] * 1000),
                f"{g[0]:.2f} / {g[1]:.2f}",
                f"{dg[0]:.2f} / {dg[1]:.2f}",
                f"{st[0]:.2f} / {st[1]:.2f}",
                f"{ds[0]:.2f} / {ds[1]:.2f}",
                f"{run['uplink_bytes_per_change_1']:.0f} / {run['uplink_bytes_per_change_10']:.0f}",
                _pair(run["dds_uplink_bytes_per_change_1"], run["dds_uplink_bytes_per_change_10"]),
            ]
        )
    headers = [
        "sites",
        "nodes",
        "zenoh: fresh client holds all (ms)",
        "one DDS domain (ms)",
        "remote get p50/p99 ms",
        "DDS get",
        "remote set p50/p99 ms",
        "DDS set",
        "uplink B/change, 1/10 viewers",
        "one DDS domain: uplink B/change, 1/10",
    ]
    skipped = {r["dds_uplink_not_measured"] for r in data["runs"]} - {None}
    text = render(headers, rows) + "".join(
        f"\n(one DDS domain's uplink not measured: {why})" for why in skipped
    )
    text += "".join(
        f"\n({r['states_not_decoded']} state(s) at {r['sites']} sites did not decode and were asked again)"
        for r in data["runs"]
        if r["states_not_decoded"]
    )
    emit(args, data, text)
    return 0


def _pair(one: float | None, ten: float | None) -> str:
    return "-" if one is None or ten is None else f"{one:.0f} / {ten:.0f}"
