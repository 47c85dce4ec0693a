"""``paramdds bench soak``: one site under churn for ``--minutes``, its long-lived processes watched.

The site (one DDS domain, ``-d``): 50 nodes in 5 ``paramdds server --persist`` processes,
restarted in turn every ~10 s (stopped cleanly and with SIGKILL in turn); 4 client processes
setting in a loop (plain, atomic, compare-and-set, and the three in turn), each writing
parameters of its own with values that only grow and keeping a ledger of what it was told;
2 monitor processes; ``paramdds web`` with 2 readers of its live stream (the page's
endpoint, ``/api/events``); a ``paramdds zenoh`` gateway with a remote monitor process
through a router in this process (zenoh extra); ``paramdds ros2`` mirroring 20 rclpy nodes
of a host process restarted every third turn (ros2 extra); a prober process timing a get
every 0.1 s. A component whose extra is missing is skipped, and said so.

After every stop and every start the viewers (the monitors, the remote monitor, the console's
node list) must agree with what the bench knows within :data:`SETTLE` seconds
(:data:`ROS_SETTLE` for the mirrors); each disagreement left then is a wrong presence. At the
end, every client's ledger is judged against the nodes' values and histories
(:func:`~._soak_checks.verify_writes`) and the viewers' values against the nodes'. RSS,
threads and open descriptors of each long-lived process are read after the warm-up (20 % of
the run, at least 20 s) and at the end. Exit 1 when a correctness check fails; growth is
reported, not judged.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import random
import shutil
import socket
import tempfile
import time
from pathlib import Path
from typing import Any

from ..exits import Terminated
from ._common import RESULT, Worker, emit, median, note, render, worker_env
from ._soak_checks import growth, stale_values, traced, verify_writes, wrong_presence
from ._soak_procs import HEAP_DIR_ENV, LiveStream, Proc, c_heap_mb, proc_stats
from ._soak_worker import client_params

NODES = 50
SERVERS = 5
CLIENTS = ("plain", "atomic", "cas", "mixed")
ROS_NODES = 20
SLOT = 10.0  # seconds from one server's stop to the next's
SETTLE = 6.0  # seconds the viewers have to show a paramdds node's stop or start
ROS_SETTLE = 15.0  # ... a mirrored ROS 2 node's (the bridge mirrors a node ~2-2.5 s after it joined)
ROS_EVERY = 3  # the rclpy host is restarted with every third server
CLIENT_RATE = 4.0  # writes a second per client
SAMPLE_EVERY = 30.0  # seconds between resource samples kept in the JSON's series
NODE = "soak_n"
ROS_NS = "soakros"


def node_names() -> list[str]:
    return [f"{NODE}{i:02d}" for i in range(NODES)]


def ros_names() -> list[str]:
    return [f"{ROS_NS}/r{i:02d}" for i in range(ROS_NODES)]


def soak_params() -> list[str]:
    return [name for k in range(len(CLIENTS)) for name in client_params(k)]


class SoakWorker(Worker):
    """A :mod:`._soak_worker` process (the READY / RESULT protocol), its stderr in a file."""

    def __init__(
        self,
        role: str,
        args: list[str],
        *,
        domain: int,
        localhost: bool,
        logs: Path,
        tag: str,
        env: dict[str, str],
    ):
        super().__init__(
            role,
            args,
            domain=domain,
            localhost=localhost,
            env=env,
            module="paramdds.bench._soak_worker",
            stderr_file=logs / f"{tag}.err",
            name=tag,
        )


def _skipped() -> dict[str, str]:
    """The components this machine cannot run, and why."""
    from ..ros2 import missing

    out: dict[str, str] = {}
    absent = [m for m in ("starlette", "uvicorn") if importlib.util.find_spec(m) is None]
    if absent:
        out["web"] = f"the web extra is not installed ({', '.join(absent)} missing)"
    if importlib.util.find_spec("zenoh") is None:
        out["zenoh"] = "the zenoh extra is not installed (zenoh missing)"
    if missing():
        out["ros2"] = missing()
    return out


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Soak:
    """The site, its churn and its checks (see the module docstring)."""

    def __init__(self, args: argparse.Namespace, tmp: Path, skipped: dict[str, str]) -> None:
        self.domain = int(args.domain)
        self.localhost = bool(args.localhost)
        self.tmp = tmp
        self.skipped = skipped
        self.heap_dir = tmp / "heap"  # each process's C heap (see _soak_procs.heap_probe)
        self.heap_dir.mkdir()
        self.env = {**worker_env(self.localhost), HEAP_DIR_ENV: str(self.heap_dir)}
        self.gflags = ["-d", str(self.domain), *(["--localhost"] if self.localhost else [])]
        self.servers: list[Proc | None] = [None] * SERVERS
        self.server_nodes = [node_names()[k::SERVERS] for k in range(SERVERS)]
        self.up = [False] * SERVERS
        self.changed = [0.0] * SERVERS  # when each server last stopped or started serving
        self.ros_up = False
        self.ros_changed = 0.0
        self.workers: dict[str, SoakWorker] = {}
        self.procs: dict[str, Proc] = {}  # the long-lived programs (not the servers, not the host)
        self.ros_host: Proc | None = None
        self.streams: list[LiveStream] = []
        self.url = ""
        self.router: Any = None
        self.ros_env: dict[str, str] = {}
        self.ros_domain: int | None = None
        self.checks: list[dict[str, Any]] = []
        counted = ("server_stops", "server_kills", "server_unclean_stops", "ros_host_restarts")
        self.events = dict.fromkeys((*counted, "ros_host_unclean_stops"), 0)

    # -- starting --------------------------------------------------------------------------

    def _server_file(self, k: int) -> Path:
        path = self.tmp / f"server{k}.yaml"
        params = "".join(f"    {name}: 0.0\n" for name in soak_params())
        path.write_text(
            "".join(f"{node}:\n  ros__parameters:\n{params}    gain: 1.5\n" for node in self.server_nodes[k])
        )
        return path

    def start_server(self, k: int) -> None:
        argv = [*self.gflags, "server", "-p", str(self.tmp / f"server{k}.yaml")]
        argv += ["--persist", str(self.tmp / f"server{k}.persist")]
        argv += [a for node in self.server_nodes[k] for a in ("-n", node)]
        proc = Proc(f"server{k}", "paramdds.cli", argv, self.env, self.tmp)
        self.servers[k] = proc
        proc.wait_for("[SERVER] Serving", len(self.server_nodes[k]))
        self.up[k], self.changed[k] = True, time.monotonic()

    def stop_server(self, k: int, kill: bool) -> None:
        proc = self.servers[k]
        if proc is not None:
            proc.stop(kill=kill)
            if not kill and proc.proc.returncode != 0:  # SIGTERM did not end it: the group was killed
                self.events["server_unclean_stops"] += 1
        self.up[k], self.changed[k] = False, time.monotonic()
        self.events["server_kills" if kill else "server_stops"] += 1

    def _acks(self, k: int) -> Path:
        """Where client ``k`` writes down the writes it was told applied (see ``traced``)."""
        return self.tmp / f"client{k}.acks"

    def _worker(self, tag: str, role: str, *argv: str) -> SoakWorker:
        w = SoakWorker(
            role,
            list(argv),
            domain=self.domain,
            localhost=self.localhost,
            logs=self.tmp,
            tag=tag,
            env=self.env,
        )
        self.workers[tag] = w
        return w

    def start(self) -> None:
        for k in range(SERVERS):
            self._server_file(k)
        note(f"{SERVERS} servers x {NODES // SERVERS} nodes (--persist)")
        for k in range(SERVERS):
            self.start_server(k)
        nodes = [a for n in node_names() for a in ("--node", n)]
        for i in (1, 2):
            self._worker(f"monitor{i}", "viewer")
        self._worker("prober", "prober", *nodes)
        for k, kind in enumerate(CLIENTS):
            rate = str(CLIENT_RATE)
            self._worker(f"client{k}", "client", "--index", str(k), "--kind", kind, "--rate", rate,
                         "--acks", str(self._acks(k)), *nodes)  # fmt: skip
        if "web" not in self.skipped:
            self._start_web()
        if "zenoh" not in self.skipped:
            self._start_zenoh()
        if "ros2" not in self.skipped:
            self._start_ros2()
        for w in self.workers.values():
            w.read("READY", 90.0)
        note("every component started; waiting for the viewers to hold every node")
        self.check("start", settle=90.0)

    def _start_web(self) -> None:
        note("web console and 2 live streams")
        web = Proc("web", "paramdds.cli", [*self.gflags, "web", "--bind", "127.0.0.1:0"], self.env, self.tmp)
        self.procs["web console"] = web
        line = web.wait_for("http://")
        self.url = "http://" + line.split("http://", 1)[1].split()[0].rstrip("/") + "/"
        # the page's two streams: the node list and log (no node), and one node's rows
        self.streams = [LiveStream(self.url), LiveStream(self.url, node_names()[0])]

    def _start_zenoh(self) -> None:
        from ..zenoh.config import open_session, router_options

        note("Zenoh router (in this process), gateway and remote monitor")
        endpoint = f"tcp/127.0.0.1:{_free_port()}"
        self.router = open_session(router_options([endpoint]))
        argv = [*self.gflags, "zenoh", "--site", "site0", "--connect", endpoint]
        gateway = Proc("gateway", "paramdds.cli", argv, self.env, self.tmp)
        self.procs["zenoh gateway"] = gateway
        gateway.wait_for("[ZENOH] Gateway")
        self._worker("remote monitor", "viewer", "--zenoh", endpoint, "--site", "site0")

    def _start_ros2(self) -> None:
        note(f"ROS 2 host of {ROS_NODES} rclpy nodes and the bridge")
        env = dict(self.env)
        # ROS_DOMAIN_ID when the bench's environment sets one other than -d (a domain no one else
        # uses on a shared machine), else a random one
        chosen = env.pop("ROS_DOMAIN_ID", "")
        others = [d for d in range(1, 100) if d != self.domain]
        ros_domain = int(chosen) if chosen.isdigit() and int(chosen) != self.domain else random.choice(others)
        self.ros_domain = ros_domain
        env.update(
            ROS_DOMAIN_ID=str(ros_domain),
            ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
            FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
            ROS_LOG_DIR=str(self.tmp / "roslog"),
        )
        self.ros_env = env
        doc = {
            f"/{n}": {"ros__parameters": {"gain": 1.5, "mode": "auto", "limits": {"speed": 2.0}}}
            for n in ros_names()
        }
        (self.tmp / "ros.yaml").write_text(json.dumps(doc))  # JSON is YAML (rcl reads it)
        self.start_ros_host()
        # at info the bridge logs how many nodes it has to mirror, each that leaves, each restart
        argv = [*self.gflags, "--log-level", "info", "ros2", "--mirror", f"/{ROS_NS}/*"]
        argv += ["--ros-domain", str(ros_domain)]
        bridge = Proc("bridge", "paramdds.cli", argv, env, self.tmp)
        self.procs["ros2 bridge"] = bridge
        bridge.wait_for("[ROS2] bridging")

    def start_ros_host(self) -> None:
        argv = ["--params-file", str(self.tmp / "ros.yaml"), "--threads", "1"]
        self.ros_host = Proc("ros_host", "paramdds.bench.ros2_host", argv, self.ros_env, self.tmp, stdin=True)
        self.ros_host.wait_for("ready")
        self.ros_up, self.ros_changed = True, time.monotonic()
        self._mark(f"the ROS 2 host (pid {self.ros_host.pid}) is ready")

    def stop_ros_host(self) -> None:
        if self.ros_host is not None:
            self._mark(f"the ROS 2 host (pid {self.ros_host.pid}) is asked to quit")
            t0 = time.monotonic()
            self.ros_host.stop()
            code = self.ros_host.proc.returncode
            self._mark(f"the ROS 2 host exited with {code} after {time.monotonic() - t0:.2f} s")
            if code != 0:  # it needed SIGTERM: its nodes linger in Fast DDS
                self.events["ros_host_unclean_stops"] += 1
        self.ros_up, self.ros_changed = False, time.monotonic()
        self.events["ros_host_restarts"] += 1

    def _mark(self, what: str) -> None:
        """A line in the bridge's log, whose own lines carry no time: the wall time (epoch seconds,
        as the viewers' .err files have it) and what the bench did to the ROS 2 host."""
        bridge = self.procs.get("ros2 bridge")
        if bridge is not None:  # its stderr is open for appending: whole lines do not mix
            with open(bridge.err, "a") as f:
                f.write(f"bench: {time.time():.3f} {what}\n")

    # -- looking ---------------------------------------------------------------------------

    def expected(self) -> dict[str, tuple[bool, float, float]]:
        """node -> (there, when that last changed, its settle time)."""
        out = {
            node: (self.up[k], self.changed[k], SETTLE)
            for k in range(SERVERS)
            for node in self.server_nodes[k]
        }
        if "ros2" not in self.skipped:
            out.update({n: (self.ros_up, self.ros_changed, ROS_SETTLE) for n in ros_names()})
        return out

    def looks(self) -> dict[str, dict[str, list[Any]]]:
        """Each viewer's nodes: node -> [online, {soak parameter: value}] (the console: no values)."""
        views: dict[str, dict[str, list[Any]]] = {}
        for tag in ("monitor1", "monitor2", "remote monitor"):
            w = self.workers.get(tag)
            if w is not None:
                w.send("look")
                views[tag] = w.read(RESULT, 30.0)["nodes"]
        if self.url:
            import urllib.request

            with urllib.request.urlopen(self.url + "api/nodes?limit=200", timeout=30) as r:
                page = json.loads(r.read())
            views["web console"] = {n["node"]: [bool(n["online"]), {}] for n in page["nodes"]}
        return views

    def check(self, what: str, settle: float | None = None) -> None:
        """Wait until every viewer shows every node as the bench knows it, or until each wrong
        node's settle time has passed; record how long that took and what was still wrong."""
        expected = self.expected()
        since = max(t for _, t, _ in expected.values())
        while True:
            now = time.monotonic()
            wrong: dict[str, dict[str, list[str]]] = {}
            late = True
            for viewer, nodes in self.looks().items():
                shown = {n: bool(v[0]) for n, v in nodes.items()}
                bad = wrong_presence(shown, {n: up for n, (up, _, _) in expected.items()})
                if bad["online_but_gone"] or bad["offline_but_there"]:
                    wrong[viewer] = bad
                    for node in bad["online_but_gone"] + bad["offline_but_there"]:
                        # a node that did not change, shown wrong, had its time since the last change
                        _, changed, wait = expected[node]
                        wait = settle if settle is not None else wait
                        late = late and now > max(changed + wait, since + SETTLE)
            if not wrong or late:
                # at: the wall time of the last change, as the viewers' .err files give theirs
                at = round(time.time() - (now - since), 3)
                self.checks.append({"what": what, "at": at, "took_s": round(now - since, 2), "wrong": wrong})
                if wrong:
                    note(f"check {what}: still wrong after the settle time: {json.dumps(wrong)}")
                return
            time.sleep(0.25)

    # -- the run ---------------------------------------------------------------------------

    def long_lived(self) -> dict[str, int]:
        """The processes whose resources are watched: name -> pid."""
        pids = {"bench (this process)": os.getpid()}
        pids.update({name: p.pid for name, p in self.procs.items()})
        pids.update({tag: w.pid for tag, w in self.workers.items()})
        return pids

    def sample(self) -> dict[str, dict[str, float] | None]:
        out = {name: proc_stats(pid, self.heap_dir) for name, pid in self.long_lived().items()}
        mine, heap = out["bench (this process)"], c_heap_mb()
        if mine is not None and heap is not None:
            mine.update(c_used_mb=heap["used"], c_free_mb=heap["free"])
        return out

    def churn(self, seconds: float) -> dict[str, Any]:
        """Restart the servers in turn (and the ROS 2 host with every third) for ``seconds``."""
        for w in self.workers.values():
            if w.role.startswith(("client", "prober")):
                w.send("go")
        t_start = time.monotonic()
        warm_at = t_start + max(0.2 * seconds, min(20.0, seconds))
        end = t_start + seconds
        warm: dict[str, Any] | None = None
        series: list[dict[str, Any]] = []
        restarts: list[list[object]] = []  # [server, "kill" or "stop", wall time stopped, started]
        next_sample = t_start
        i = 0
        while time.monotonic() < end:
            t0 = time.monotonic()
            k = i % SERVERS
            kill = i % 2 == 1  # SERVERS is odd: each server is killed in every other of its turns
            ros = "ros2" not in self.skipped and i % ROS_EVERY == ROS_EVERY - 1
            restarts.append([k, "kill" if kill else "stop", round(time.time(), 3)])
            self.stop_server(k, kill)
            if ros:
                self.stop_ros_host()
            self.check(
                f"server{k} {'killed' if kill else 'stopped'}" + (", ROS 2 host stopped" if ros else "")
            )
            self.start_server(k)
            restarts[-1].append(round(time.time(), 3))
            if ros:
                self.start_ros_host()
            self.check(f"server{k} started" + (", ROS 2 host started" if ros else ""))
            i += 1
            if (now := time.monotonic()) >= next_sample:  # also when the turn outlasted its slot
                series.append({"at_s": round(now - t_start, 1), "processes": self.sample()})
                next_sample = now + SAMPLE_EVERY
            while (now := time.monotonic()) < min(t0 + SLOT, end) or (warm is None and now >= warm_at):
                if warm is None and now >= warm_at:  # on time, between two turns
                    warm = {"at_s": round(now - t_start, 1), "processes": self.sample()}
                    note(f"warm-up sample at {warm['at_s']} s")
                    continue
                if now >= next_sample:
                    series.append({"at_s": round(now - t_start, 1), "processes": self.sample()})
                    next_sample = now + SAMPLE_EVERY
                wake = min(t0 + SLOT, end, next_sample, warm_at if warm is None else end)
                time.sleep(max(0.0, min(wake - now, 1.0)))
        final = {"at_s": round(time.monotonic() - t_start, 1), "processes": self.sample()}
        if warm is None:  # a run shorter than one turn of the churn
            warm = final
        return {"turns": i, "seconds": round(time.monotonic() - t_start, 1), "warm": warm, "end": final,
                "series": series, "restarts": restarts}  # fmt: skip

    def finish(self) -> dict[str, Any]:
        """Stop the clients and the prober, then judge what they were told and what is shown."""
        dead = [name for name, p in self.procs.items() if not p.alive()]
        dead += [tag for tag, w in self.workers.items() if w.proc.poll() is not None]
        for w in self.workers.values():
            if w.role.startswith(("client", "prober")):
                w.send("stop")
        results = {
            tag: w.read(RESULT, 60.0)
            for tag, w in self.workers.items()
            if w.role.startswith(("client", "prober"))
        }
        finals, applied, compacted = self._read_nodes()
        verdict = verify_writes(
            [results[f"client{k}"]["ledger"] for k in range(len(CLIENTS))], finals, applied, compacted
        )
        stale = self._stale(finals)
        acks = [self._acks(k) for k in range(len(CLIENTS))]
        return {
            "writes": {**verdict.to_json(), "lost_acknowledged_as": traced(verdict.lost, acks)},
            "writes_ok": verdict.ok,
            "clients": {
                f"client{k} ({kind})": results[f"client{k}"]["counts"] for k, kind in enumerate(CLIENTS)
            },
            "get": {
                "gets": results["prober"]["gets"],
                "ms": {q: round(v, 2) for q, v in results["prober"]["ms"].items()},
                "failed": results["prober"]["failed"],
            },
            "stale_values": stale,
            "died": dead,
            "streams": [s.summary() for s in self.streams],
        }  # fmt: skip

    def _read_nodes(self) -> tuple[dict[str, dict[str, float]], dict[str, dict[str, set[int]]], list[str]]:
        """Each node's soak values, the values its history applied, and the nodes whose history
        retention dropped records (read by a client in this process)."""
        from ..dds.client import ParameterClient
        from ..dds.participant import close_participant, make_participant

        dp = make_participant(self.domain, localhost=self.localhost, app_name="soak-check")
        names = soak_params()
        finals: dict[str, dict[str, float]] = {}
        applied: dict[str, dict[str, set[int]]] = {}
        compacted: list[str] = []
        try:
            client = ParameterClient(dp, timeout=10.0)
            for node in node_names():
                client.wait_for_node(node, 30.0)
                values = client.get(node, names).values()
                finals[node] = {n: float(v.to_python()) for n, v in values.items()}  # type: ignore[arg-type]
                history = client.history(node, names, timeout=30.0)
                if history.compacted:
                    compacted.append(node)
                for r in history.records:
                    if r.applied and r.new is not None:
                        applied.setdefault(node, {}).setdefault(r.name, set()).add(int(r.new.to_python()))  # type: ignore[call-overload]
            client.close()
        finally:
            close_participant(dp)
        return finals, applied, compacted

    def _stale(self, finals: dict[str, dict[str, float]]) -> dict[str, list[str]]:
        """What each viewer holding values shows otherwise than the nodes, after the settle time."""
        deadline = time.monotonic() + SETTLE
        while True:
            out: dict[str, list[str]] = {}
            for viewer, nodes in self.looks().items():
                if viewer == "web console":
                    continue
                stale = stale_values({n: v[1] for n, v in nodes.items() if n in finals}, finals)
                if stale:
                    out[viewer] = stale
            if not out or time.monotonic() > deadline:
                return out
            time.sleep(0.25)

    def close(self) -> None:
        for s in self.streams:
            s.close()
        for w in self.workers.values():
            w.stop()
        for p in [*self.procs.values(), self.ros_host, *self.servers]:
            if p is not None:
                p.stop(grace=10.0)
        if self.router is not None:
            self.router.close()


def run(args: argparse.Namespace) -> int:
    minutes = args.minutes if getattr(args, "minutes", None) else (1.0 if args.quick else 60.0)
    skipped = _skipped()
    for what, why in skipped.items():
        note(f"{what} skipped: {why}")
    tmp = Path(tempfile.mkdtemp(prefix="paramdds-soak-"))  # kept when the run fails: its logs
    soak = Soak(args, tmp, skipped)
    stopped = False
    try:
        soak.start()
        note(f"churn for {minutes:g} min")
        run_data = soak.churn(minutes * 60.0)
        note("churn over: judging the writes and the viewers")
        judged = soak.finish()
    except Terminated:  # SIGTERM: a graceful stop (every process is stopped below), nothing judged
        stopped = True
        raise
    except Exception as exc:
        raise RuntimeError(f"bench soak: {exc} (every process's output is in {tmp})") from exc
    finally:
        soak.close()
        if stopped:  # once every process is stopped: none writes into it any more
            shutil.rmtree(tmp, ignore_errors=True)
    data = _data(minutes, skipped, soak, run_data, judged)
    if data["passed"]:
        shutil.rmtree(tmp, ignore_errors=True)
    else:
        data["logs"] = str(tmp)
        note(f"every process's output (the viewers' presence events in their .err) is kept in {tmp}")
    emit(args, data, table(data))
    return 0 if data["passed"] else 1


def _data(
    minutes: float, skipped: dict[str, str], soak: Soak, run: dict[str, Any], judged: dict[str, Any]
) -> dict[str, Any]:
    processes = {}
    for name, before in run["warm"]["processes"].items():
        after = run["end"]["processes"].get(name)
        if before is None or after is None:
            processes[name] = {"warm": before, "end": after, "growth_pct": None}
            continue
        processes[name] = {
            "warm": before,
            "end": after,
            "growth_pct": {k: growth(before[k], after[k]) for k in ("rss_mb", "threads", "fds")},
        }
    took = [c["took_s"] for c in soak.checks if c["what"] != "start"]
    wrong = [c for c in soak.checks if c["wrong"]]
    streams_ok = all(s["reconnects"] == 0 and s["quiet_s"] < 30.0 for s in judged["streams"])
    passed = (
        judged["writes_ok"]
        and not wrong
        and not judged["stale_values"]
        and not judged["died"]
        and streams_ok
        and not soak.events["server_unclean_stops"]  # a server SIGTERM did not end
    )
    return {
        "minutes": minutes,
        "nodes": NODES,
        "servers": SERVERS,
        "ros_nodes": 0 if "ros2" in skipped else ROS_NODES,
        "ros_domain": soak.ros_domain,
        "skipped": skipped,
        "churn": {**{k: v for k, v in run.items() if k in ("turns", "seconds", "restarts")}, **soak.events},
        "warm_at_s": run["warm"]["at_s"],
        "end_at_s": run["end"]["at_s"],
        "processes": processes,
        "series": run["series"],
        "presence": {
            "checks": len(took),
            "agreed_p50_s": median(took) if took else None,
            "agreed_max_s": max(took) if took else None,
            "wrong": wrong,
        },
        **{k: v for k, v in judged.items() if k != "writes_ok"},
        "passed": passed,
        "load_average": list(os.getloadavg()),
    }


def table(data: dict[str, Any]) -> str:
    rows = []
    for name, p in data["processes"].items():
        w, e, g = p["warm"], p["end"], p["growth_pct"]
        if w is None or e is None or g is None:
            rows.append([name, "gone", "", "", "", "", "", "", "", "", ""])
            continue
        heap = f"{w['c_used_mb']} -> {e['c_used_mb']}" if "c_used_mb" in w and "c_used_mb" in e else ""
        rows.append(
            [name, w["rss_mb"], e["rss_mb"], f"{g['rss_mb']:+.1f}", heap,
             int(w["threads"]), int(e["threads"]), f"{g['threads']:+.1f}",
             int(w["fds"]), int(e["fds"]), f"{g['fds']:+.1f}"]
        )  # fmt: skip
    heads = [
        "process",
        "RSS MiB warm",
        "end",
        "%",
        "C in use MiB",
        "threads warm",
        "end",
        "%",
        "fds warm",
        "end",
        "%",
    ]
    c, wr, get, pr = data["churn"], data["writes"], data["get"], data["presence"]
    ms = get["ms"] or {"p50": float("nan"), "p99": float("nan"), "max": float("nan")}
    lines = [
        f"soak: {data['minutes']:g} min, {data['nodes']} nodes in {data['servers']} servers, "
        f"{data['ros_nodes']} mirrored rclpy nodes; warm-up sample at {data['warm_at_s']} s, "
        f"end at {data['end_at_s']} s",
        render(heads, rows),
        f"churn: {c['turns']} server restarts ({c['server_stops']} clean, {c['server_kills']} SIGKILL), "
        f"{c['ros_host_restarts']} ROS 2 host restarts; stops that needed SIGKILL: "
        f"{c['server_unclean_stops']} servers, {c['ros_host_unclean_stops']} ROS 2 hosts",
        f"writes: {wr['acknowledged']} acknowledged, {wr['failed']} reported failed, "
        f"{wr['unknown']} outcome unknown "
        f"({wr['unknown_landed']} of them applied); lost {len(wr['lost'])}, failed but landed "
        f"{len(wr['failed_but_landed'])}, wrong final value {len(wr['wrong_final'])}",
        *(f"  lost: {x}" for x in wr["lost_acknowledged_as"]),
        *(f"  failed but landed: {x}" for x in wr["failed_but_landed"]),
        *(f"  wrong final value: {x}" for x in wr["wrong_final"]),
        f"presence: {pr['checks']} checks, viewers agreed in {pr['agreed_p50_s']} s at the median, "
        f"{pr['agreed_max_s']} s at most; wrong after the settle time: {len(pr['wrong'])}",
        f"viewers' values unlike the nodes' at the end: {sum(len(v) for v in data['stale_values'].values())}",
        f"get during churn: {get['gets']} answered, p50 {ms['p50']:.2f} ms, p99 {ms['p99']:.2f} ms, "
        f"max {ms['max']:.1f} ms; failed: {get['failed'] or 'none'}",
    ]
    for i, s in enumerate(data["streams"]):
        lines.append(f"live stream {i + 1}: {s['events']}, {s['reconnects']} reconnects")
    if data["died"]:
        lines.append(f"DIED: {', '.join(data['died'])}")
    for what, why in data["skipped"].items():
        lines.append(f"skipped {what}: {why}")
    lines.append("PASSED" if data["passed"] else "FAILED (a correctness check failed: see the JSON, -o json)")
    return "\n".join(lines)
