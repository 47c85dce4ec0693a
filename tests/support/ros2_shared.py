"""ROS 2 and paramdds on one domain id: ``python -m tests.support.ros2_shared`` (from the checkout).

Real processes on one domain id (ROS 2's ``ROS_DOMAIN_ID`` and paramdds's the same number),
loopback only: rclpy host processes (the nodes of ``--params-file``, default the nav2
file of ``realworld/``, or ``--nodes N`` synthetic nodes spread over ``--hosts H``
processes, each node with ``--unknown K`` publishers of message types the bridge does not
know), a ``paramdds server``, a ``paramdds watch`` (a monitor), and a monitor in this
process. Then:

* ``--starts K`` bridge starts: ``paramdds ros2`` mirroring the hosts' nodes, timed from its
  start until this process's monitor holds every node mirrored (online, complete, origin
  ``ros2``, no status), then stopped (SIGTERM), and the next start waits until every mirror
  is offline. With ``--starve`` the bridge is starved of CPU all its life (SIGSTOP, then
  SIGCONT 0.3-2.5 s later, at random moments), as on a loaded machine;
* ``--stalls 5,25,60`` after each start (with ``--stall-every K``, after every K-th start):
  one host process (each in turn) stopped for each of those seconds (SIGSTOP, as a
  debugger breakpoint or a swap storm does), timed from its SIGCONT until every node is
  mirrored again;
* ``--tools`` fresh rclpy processes (what ``ros2 param list`` does: learn the graph, then
  a parameter client per node) that list the parameters of every node, with the bridge
  of the last start still up.

Prints the time from each start to all nodes mirrored and from each SIGCONT to all nodes
mirrored again (min / median / max), the bridges that died (exit code, and the crashing
thread's stack from faulthandler), the nodes left unmirrored, and how many nodes each tool
reached. ``--type-lookup on`` gives the bridge a Fast DDS profile of its own, so its ROS 2
participant keeps XTypes type lookup (as before it turned it off), to compare. No Cyclone
discovery tag may be set (``CYCLONEDDS_URI`` is dropped): Fast DDS knows no tags, and with
one Cyclone would not meet ROS 2 at all.
``tests/ros2/test_shared_domain.py`` runs the same steps; this measures them (docs/ros2.md,
"One domain id"). A harness of the tests, not a benchmark of ``paramdds bench``: it needs the
``ros2`` extra and a checkout (it runs ``python -m paramdds.bench.ros2_host``, the rclpy host
that ``paramdds bench ros2`` also runs).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from statistics import median
from typing import Any

from tests.support.realworld import ROOT, find_realworld

START_TIMEOUT = 60.0  # seconds a bridge start may take to mirror every node before it counts as failed
TOOL_TIMEOUT = 30.0
RECOVER_TIMEOUT = 60.0  # seconds after a stall's SIGCONT for every node to be mirrored again
RECOVER_WITHIN = 5.0  # seconds the issue asks for; the bridge's log of a stall that took longer is printed
STARVE_STOP = (0.3, 2.5)  # seconds the starved bridge stays stopped each time (uniform)
STARVE_RUN = (0.2, 2.0)  # seconds it runs between two stops (uniform)
# a Fast DDS profiles file of the user's own that keeps type lookup on in its default participant
# profile (paramdds.ros2.fastdds_profile: a value the user sets holds)
TYPE_LOOKUP_ON_XML = """<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com"><profiles>
  <participant profile_name="type_lookup_on" is_default_profile="true"><rtps><propertiesPolicy><properties>
    <property><name>fastdds.type_propagation</name><value>enabled</value></property>
  </properties></propertiesPolicy></rtps></participant>
</profiles></dds>
"""


def shared_env(domain: int, tmp: Path, base: dict[str, str] | None = None) -> dict[str, str]:
    """The environment of every process: both stacks on ``domain``, loopback, UDP only (no Fast
    DDS shared memory), ROS logs under ``tmp``, no Cyclone discovery tag."""
    env = dict(os.environ if base is None else base)
    env.pop("CYCLONEDDS_URI", None)
    env.update(
        ROS_DOMAIN_ID=str(domain),
        PARAMDDS_DOMAIN=str(domain),
        PARAMDDS_LOCALHOST="1",
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
        ROS_LOG_DIR=str(tmp / "roslog"),
        PYTHONUNBUFFERED="1",
    )
    return env


def _python(*args: str) -> list[str]:
    return [sys.executable, *args]


class _Proc:
    """A process started in its own session, stopped with SIGTERM (then killed) at the end."""

    def __init__(
        self,
        cmd: Sequence[str],
        env: dict[str, str],
        ready: str = "",
        timeout: float = 60.0,
        log: Path | None = None,
    ) -> None:
        self.log = log  # its stderr, to say why when it did not do its part
        with open(log, "w") if log is not None else contextlib.nullcontext() as err:
            self.proc = subprocess.Popen(
                list(cmd),
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE if ready else subprocess.DEVNULL,
                stderr=err if err is not None else subprocess.DEVNULL,
                text=True,
                env=env,
                start_new_session=True,
            )
        self.first = ""
        if ready:
            assert self.proc.stdout is not None
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                line = self.proc.stdout.readline()
                if not line:
                    raise RuntimeError(f"{' '.join(cmd[:4])} exited before it was ready")
                if line.startswith(ready):
                    self.first = line.strip()
                    break

    def tail(self, chars: int = 3000) -> str:
        """The end of its stderr (empty without a log); for a process that crashed, faulthandler's
        report instead: the crashing thread's stack first, then the others (up to CRASH_CHARS)."""
        if self.log is None or not self.log.exists():
            return ""
        text = self.log.read_text(errors="replace")
        return crash_report(text) or text[-chars:]

    def stop(self) -> None:
        if self.proc.poll() is None:
            try:
                assert self.proc.stdin is not None
                self.proc.stdin.write("quit\n")  # the rclpy host shuts down cleanly on it
                self.proc.stdin.close()
                self.proc.wait(timeout=5 if self.first.startswith("ready") else 0.01)
            except (OSError, subprocess.TimeoutExpired):
                pass
            if self.proc.poll() is None:
                self.proc.send_signal(signal.SIGTERM)  # SIGINT is ignored in a background job
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                if self.log is not None:  # a bridge: faulthandler writes every thread's stack to its log
                    with contextlib.suppress(OSError):
                        self.proc.send_signal(signal.SIGUSR1)
                    time.sleep(1.0)
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None and not stream.closed:
                stream.close()


CRASH_CHARS = 20000  # how much of a crash report a diagnosis shows (a bridge has ~30 threads)


def crash_report(text: str) -> str:
    """faulthandler's report in a process's stderr (``Fatal Python error: ...`` and every
    thread's stack), the crashing thread's stack first; empty when there is none."""
    start = text.find("Fatal Python error")
    if start < 0:
        return ""
    report = text[start:]
    before, found, rest = report.partition("\nCurrent thread ")
    if found:  # the crashing thread's block (up to the next blank line) to the front
        block, _, after = rest.partition("\n\n")
        first, _, others = before.partition("\n")
        report = f"{first}\nCurrent thread {block}\n\nThe other threads:{others}\n\n{after}"
    return report[:CRASH_CHARS]


@dataclass
class Graph:
    """The ROS 2 side of a shared domain: the host processes and the nodes of each."""

    hosts: list[_Proc] = field(default_factory=list)
    nodes_of: list[list[str]] = field(default_factory=list)

    @property
    def nodes(self) -> list[str]:
        return [n for ns in self.nodes_of for n in ns]


@contextmanager
def shared_graph(env: dict[str, str], *host_args: Sequence[str]) -> Iterator[Graph]:
    """An rclpy host process per ``host_args`` (``paramdds.bench.ros2_host`` with those
    arguments), a paramdds server and a ``paramdds watch`` on the domain of ``env``."""
    procs: list[_Proc] = []
    graph = Graph()
    try:
        for args in host_args:
            host = _Proc(_python("-m", "paramdds.bench.ros2_host", *args), env, ready="ready")
            procs.append(host)
            graph.hosts.append(host)
            graph.nodes_of.append(host.first.split()[1:])
        server_args = ("-m", "paramdds.cli", "server", "-n", "shared_domain_probe", "--use-sim-time")
        procs.append(_Proc(_python(*server_args), env, ready="[SERVER] Serving"))
        procs.append(_Proc(_python("-m", "paramdds.cli", "watch"), env))
        yield graph
    finally:
        for host in graph.hosts:  # a stopped host cannot quit
            with contextlib.suppress(ProcessLookupError):
                os.kill(host.proc.pid, signal.SIGCONT)
        for p in reversed(procs):
            p.stop()


@contextmanager
def shared_domain(env: dict[str, str], host_args: Sequence[str]) -> Iterator[list[str]]:
    """The rclpy host (``paramdds.bench.ros2_host`` with ``host_args``), a paramdds server and a
    ``paramdds watch`` on the domain of ``env``; yields the host's nodes (``/ns/name``)."""
    with shared_graph(env, host_args) as graph:
        yield graph.nodes


def mirrored(monitor: Any, nodes: Sequence[str]) -> int:
    """How many of ``nodes`` the monitor holds mirrored: online, complete, origin ``ros2``, and no
    status (not ``unreachable``, not ``stale``)."""
    snap = monitor.snapshot()
    return sum(
        1
        for n in nodes
        if (st := snap.get(n.lstrip("/"))) is not None
        and st.online
        and st.complete
        and st.origin == "ros2"
        and st.status is None
    )


class Starver:
    """Starves a process of CPU until :meth:`stop`: SIGSTOP, SIGCONT ``STARVE_STOP`` seconds
    later, again ``STARVE_RUN`` seconds after that (a thread of this process)."""

    def __init__(self, pid: int, seed: int | None = None) -> None:
        self.pid = pid
        self._stops: list[tuple[float, float]] = []  # (SIGSTOP, SIGCONT), monotonic; inf while stopped
        self._random = random.Random(seed)
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="starver", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._done.wait(self._random.uniform(*STARVE_RUN)):
            pause = self._random.uniform(*STARVE_STOP)
            try:
                os.kill(self.pid, signal.SIGSTOP)
                self._stops.append((time.monotonic(), float("inf")))
                self._done.wait(pause)
            except ProcessLookupError:
                return
            finally:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(self.pid, signal.SIGCONT)
                if self._stops and self._stops[-1][1] == float("inf"):
                    self._stops[-1] = (self._stops[-1][0], time.monotonic())

    @property
    def stops(self) -> int:
        return len(self._stops)

    @property
    def stopped(self) -> float:
        """Seconds stopped in all (those of a stop in progress not counted)."""
        return sum(b - a for a, b in list(self._stops) if b != float("inf"))

    def ran(self, start: float, end: float) -> float:
        """Seconds the process ran (was not stopped by us) from ``start`` to ``end`` (monotonic)."""
        stopped = sum(max(0.0, min(b, end) - max(a, start)) for a, b in list(self._stops))
        return round(end - start - stopped, 2)

    def stop(self) -> None:
        """Stop starving it (it runs on when this returns)."""
        self._done.set()
        self._thread.join()


def holding(monitor: Any, nodes: Sequence[str]) -> dict[str, int]:
    """What the monitor holds of ``nodes``: how many in each state."""
    snap = monitor.snapshot()
    held: dict[str, int] = {}
    for n in nodes:
        st = snap.get(n.lstrip("/"))
        key = (
            "absent"
            if st is None
            else f"online={st.online} complete={st.complete} origin={st.origin} status={st.status}"
        )
        held[key] = held.get(key, 0) + 1
    return held


def diagnosis(monitor: Any, nodes: Sequence[str], bridge: _Proc) -> str:
    """Why a start is incomplete: what the monitor holds of ``nodes`` and the bridge's state."""
    snap = monitor.snapshot()
    held = holding(monitor, nodes)
    others = sorted(k for k in snap if "/" + k not in nodes and k not in nodes)[:10]
    code = bridge.proc.poll()
    return (
        f"{mirrored(monitor, nodes)} of {len(nodes)} mirrored; the monitor holds {held}; other nodes "
        f"{others}; the bridge {'is running' if code is None else f'exited with {code}'}; its log ends:\n"
        f"{bridge.tail()}"
    )


def _wait(check: Any, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if check():
            return True
        time.sleep(0.05)
    return False


def bridge_start(
    env: dict[str, str], nodes: Sequence[str], monitor: Any, *, glob: str, timeout: float = START_TIMEOUT
) -> tuple[float | None, _Proc]:
    """Start ``paramdds ros2 --mirror GLOB``: seconds until ``monitor`` holds all ``nodes``
    mirrored (None: not within ``timeout``), and the running bridge."""
    t0 = time.monotonic()
    log = Path(env["ROS_LOG_DIR"]).parent / f"bridge-{time.time_ns()}.log"
    cmd = _python("-m", "paramdds.cli", "--log-level", "info", "ros2", "--mirror", glob, "--resync", "0")
    bridge = _Proc(cmd, env, log=log)
    done = _wait(lambda: mirrored(monitor, nodes) == len(nodes), timeout)
    return (round(time.monotonic() - t0, 2) if done else None), bridge


def stop_bridge(bridge: _Proc, monitor: Any, nodes: Sequence[str]) -> None:
    """Stop a bridge and wait until its mirrors are offline (the next start begins from none)."""
    bridge.stop()
    _wait(lambda: not any((st := monitor.snapshot().get(n.lstrip("/"))) and st.online for n in nodes), 15.0)


def tool(env: dict[str, str], nodes: Sequence[str], timeout: float = TOOL_TIMEOUT) -> dict[str, Any]:
    """A fresh rclpy process that lists every node's parameters as ``ros2 param list`` does."""
    out = subprocess.run(
        _python("-m", "tests.support.ros2_shared", "tool", "--timeout", str(timeout), *nodes),
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout + 30,
        check=False,
    )
    if out.returncode != 0:
        raise RuntimeError(f"the rclpy tool failed: {out.stderr[-2000:]}")
    result: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def _tool_main(nodes: Sequence[str], timeout: float) -> dict[str, Any]:
    """The tool process: the graph first (as the ros2 CLI learns it), then one
    ``list_parameters`` call per node, all in flight at once, each bounded by ``timeout``."""
    from paramdds.ros2.rosside import quiet_imports

    quiet_imports()
    import rclpy
    from rcl_interfaces.srv import ListParameters
    from rclpy.executors import SingleThreadedExecutor

    rclpy.init()
    # /rosout on (rclpy's default): Fast DDS then knows the type of every node's /rosout writer
    # and never looks it up (that type lookup can crash the process, see paramdds.ros2.rosside)
    node = rclpy.create_node("paramdds_shared_domain_tool")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    t0 = time.monotonic()
    wanted = set(nodes)
    while time.monotonic() - t0 < timeout:
        seen = {f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces()}
        if wanted <= seen:
            break
        executor.spin_once(timeout_sec=0.05)
    clients: dict[str, Any] = {f: node.create_client(ListParameters, f"{f}/list_parameters") for f in nodes}
    futures: dict[str, Any] = {}
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not (
        len(futures) == len(nodes) and all(f.done() for f in futures.values())
    ):
        for fqn, client in clients.items():
            if fqn not in futures and client.service_is_ready():
                futures[fqn] = client.call_async(ListParameters.Request())
        executor.spin_once(timeout_sec=0.02)
    reached = sorted(f for f, fut in futures.items() if fut.done() and fut.result() is not None)
    result = {
        "reached": len(reached),
        "missing": sorted(set(nodes) - set(reached)),
        "seconds": round(time.monotonic() - t0, 2),
    }
    executor.shutdown(timeout_sec=1.0)
    node.destroy_node()
    rclpy.shutdown()
    return result


def _host_args(args: argparse.Namespace) -> tuple[list[list[str]], str]:
    """Each host process's arguments, and the bridge's mirror glob."""
    extra = ["--unknown", str(args.unknown)] if args.unknown else []
    if args.nodes:
        hosts = max(1, min(args.hosts, args.nodes))
        names = [f"/shared/n{i:03d}" for i in range(args.nodes)]
        return [
            [*extra, *(a for n in names[h::hosts] for a in ("--node", n))] for h in range(hosts)
        ], "/shared/*"
    where = find_realworld()
    path = Path(args.params_file) if args.params_file else (where / "nav2_params.yaml" if where else None)
    if path is None or not path.is_file():
        raise SystemExit("no parameter file: give --params-file, or --nodes N")
    return [[*extra, "--params-file", str(path)]], "*"


def spread(values: Sequence[float | None]) -> dict[str, Any]:
    """Seconds (None: not done in time): how many were done, min / median / max of those."""
    done = [v for v in values if v is not None]
    return {
        "seconds": list(values),
        "complete": len(done),
        "min": min(done) if done else None,
        "median": round(median(done), 2) if done else None,
        "max": max(done) if done else None,
    }


def _ros_said(bridge: _Proc) -> list[str]:
    """The lines of the bridge's log from its ROS 2 side, so far."""
    said = bridge.log.read_text(errors="replace").splitlines() if bridge.log else []
    return [x for x in said if "paramdds.ros2." in x]


def _dead(bridge: _Proc, start: int, when: str, dead: list[dict[str, Any]]) -> None:
    """Record in ``dead`` a bridge that has exited by itself (its exit code and the end of its
    log, faulthandler's report first when it crashed)."""
    code = bridge.proc.poll()
    if code is not None:
        report = bridge.tail()[:4000]
        dead.append({"start": start, "when": when, "exit": code, "report": report})
        print(
            f"start {start}: the bridge DIED (during the {when}) with exit {code}:\n{report}", file=sys.stderr
        )


@dataclass
class Stall:
    """One stall of a host process: seconds from its SIGCONT until every node was mirrored again
    (None: not within the timeout), the nodes not mirrored then, the most nodes shown not
    mirrored while it was stopped (0: the bridge did not notice the stall), and of the seconds
    to all mirrored those the bridge ran (None: not starved)."""

    recovered: float | None
    missing: int
    noticed: int
    ran: float | None = None


def _stall(
    graph: Graph, index: int, seconds: float, monitor: Any, timeout: float, starver: Starver | None = None
) -> Stall:
    """Stop host ``index`` (SIGSTOP) for ``seconds``, then SIGCONT; what the monitor showed."""
    pid = graph.hosts[index].proc.pid
    nodes = graph.nodes
    noticed = 0
    os.kill(pid, signal.SIGSTOP)
    try:
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            noticed = max(noticed, len(nodes) - mirrored(monitor, nodes))
            time.sleep(min(0.1, max(0.0, until - time.monotonic())))
    finally:
        os.kill(pid, signal.SIGCONT)
    t0 = time.monotonic()
    done = _wait(lambda: mirrored(monitor, nodes) == len(nodes), timeout)
    t1 = time.monotonic()
    took = round(t1 - t0, 2) if done else None
    ran = starver.ran(t0, t1) if starver is not None and done else None
    return Stall(took, len(nodes) - mirrored(monitor, nodes), noticed, ran)


def run(args: argparse.Namespace) -> dict[str, Any]:
    from paramdds.dds.monitor import ParameterMonitor
    from paramdds.dds.participant import close_participant, make_participant

    host_args, glob = _host_args(args)
    stalls = [float(x) for x in args.stalls.split(",") if x.strip()] if args.stalls else []
    with tempfile.TemporaryDirectory(prefix="paramdds-ros2-shared-") as tmp:
        env = shared_env(args.domain, Path(tmp))
        os.environ.pop("CYCLONEDDS_URI", None)
        if args.cyclone_uri:
            env["CYCLONEDDS_URI"] = os.environ["CYCLONEDDS_URI"] = args.cyclone_uri
        bridge_env = dict(env)
        if args.type_lookup == "on":
            profiles = Path(tmp) / "profiles.xml"
            profiles.write_text(TYPE_LOOKUP_ON_XML)
            bridge_env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(profiles)
        with shared_graph(env, *host_args) as graph:
            nodes = graph.nodes
            dp = make_participant(args.domain, localhost=True)
            monitor = ParameterMonitor(dp)
            times: list[float | None] = []
            recovered: dict[float, list[float | None]] = {s: [] for s in stalls}
            noticed: dict[float, list[int]] = {s: [] for s in stalls}
            ran: dict[float, list[float | None]] = {s: [] for s in stalls}
            unmirrored: list[dict[str, Any]] = []
            dead: list[dict[str, Any]] = []
            tools: list[dict[str, Any]] = []
            starved: dict[str, float] = {"stops": 0, "seconds": 0.0}
            bridge: _Proc | None = None
            starver: Starver | None = None
            turn = 0
            try:
                for i in range(1, args.starts + 1):
                    if bridge is not None:
                        stop_bridge(bridge, monitor, nodes)  # also when it died: its mirrors go offline
                    t0 = time.monotonic()
                    log = Path(tmp) / f"bridge-{i}.log"
                    cmd = _python(
                        "-m", "paramdds.cli", "--log-level", "info", "ros2", "--mirror", glob, "--resync", "0"
                    )
                    bridge = _Proc(cmd, bridge_env, log=log)
                    starver = Starver(bridge.proc.pid) if args.starve else None
                    complete = _wait(
                        lambda b=bridge: mirrored(monitor, nodes) == len(nodes) or b.proc.poll() is not None,
                        args.start_timeout,
                    ) and mirrored(monitor, nodes) == len(nodes)
                    took = round(time.monotonic() - t0, 2) if complete else None
                    times.append(took)
                    if not complete:
                        missing = len(nodes) - mirrored(monitor, nodes)
                        unmirrored.append(
                            {"start": i, "when": "start", "missing": missing, "held": holding(monitor, nodes)}
                        )
                    print(f"start {i}: {took if took is not None else 'INCOMPLETE'} s", file=sys.stderr)
                    phase = "start"
                    stalling = bridge.proc.poll() is None and i % args.stall_every == 0
                    for seconds in stalls if stalling else []:
                        phase = f"stall {seconds:g} s"
                        said_before = len(_ros_said(bridge))
                        stall = _stall(
                            graph, turn % len(graph.hosts), seconds, monitor, args.recover_timeout, starver
                        )
                        turn += 1
                        recovered[seconds].append(stall.recovered)
                        noticed[seconds].append(stall.noticed)
                        ran[seconds].append(stall.ran)
                        if stall.missing:  # what the monitor holds; why: what the bridge's ROS 2 side said
                            held = holding(monitor, nodes)
                            miss = {"start": i, "when": phase, "missing": stall.missing, "held": held}
                            unmirrored.append(miss)
                            ros = "\n".join(_ros_said(bridge)[-60:])
                            print(f"start {i}: {phase}: {held}; the bridge said:\n{ros}", file=sys.stderr)
                        elif stall.recovered is not None and stall.recovered > RECOVER_WITHIN:
                            ros = "\n".join(_ros_said(bridge)[said_before:][-60:])
                            print(f"start {i}: {phase}: slow; the bridge said:\n{ros}", file=sys.stderr)
                        again = f"{stall.recovered} s" if stall.recovered is not None else "NOT"
                        running = f", the bridge running {stall.ran} s of it" if stall.ran is not None else ""
                        print(
                            f"start {i}: {phase}, {stall.noticed} nodes shown not mirrored during it, "
                            f"all mirrored again {again} after SIGCONT{running} ({stall.missing} missing)",
                            file=sys.stderr,
                        )
                        if bridge.proc.poll() is not None:
                            break
                    if starver is not None:
                        starver.stop()
                        starved["stops"] += starver.stops
                        starved["seconds"] = round(starved["seconds"] + starver.stopped, 1)
                        starver = None
                    _dead(bridge, i, phase, dead)
                for _ in range(args.tools):
                    tools.append(tool(env, nodes))
            finally:
                if starver is not None:
                    starver.stop()
                if bridge is not None:
                    bridge.stop()
                monitor.close()
                close_participant(dp)
    return {
        "nodes": len(nodes),
        "hosts": len(host_args),
        "unknown_per_node": args.unknown,
        "type_lookup": args.type_lookup,
        "starved": starved if args.starve else None,
        "starts": len(times),
        "dead": dead,
        "unmirrored": unmirrored,
        "start": spread(times),
        "stalls": {
            f"{s:g}": {
                **spread(v),
                "noticed": noticed[s],
                "bridge_ran": spread(ran[s]) if args.starve else None,
            }
            for s, v in recovered.items()
        },
        "tools": tools,
    }


def ok(result: dict[str, Any]) -> bool:
    """No bridge died, every start mirrored every node, every stall ended with all mirrored again."""
    return not result["dead"] and not result["unmirrored"] and result["start"]["complete"] == result["starts"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m tests.support.ros2_shared", description="ROS 2 and paramdds on one domain id"
    )
    sub = ap.add_subparsers(dest="mode")
    t = sub.add_parser("tool", help="(internal) one fresh rclpy tool process")
    t.add_argument("--timeout", type=float, default=TOOL_TIMEOUT)
    t.add_argument("fqn", nargs="+")
    ap.add_argument("-d", "--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "47")))
    ap.add_argument("--params-file", help="the host's nodes (default: realworld/nav2_params.yaml)")
    ap.add_argument("--nodes", type=int, default=0, help="N synthetic nodes instead of a parameter file")
    ap.add_argument("--hosts", type=int, default=1, help="host processes the N nodes are spread over")
    ap.add_argument(
        "--unknown", type=int, default=0, help="publishers per node of types the bridge does not know"
    )
    ap.add_argument("--starts", type=int, default=10)
    ap.add_argument("--starve", action="store_true", help="SIGSTOP/SIGCONT the bridge at random (0.3-2.5 s)")
    ap.add_argument(
        "--stalls", default="", help="seconds, comma-separated: a host stopped so long after each start"
    )
    ap.add_argument(
        "--stall-every", type=int, default=1, metavar="K", help="stall after every K-th start (%(default)s)"
    )
    ap.add_argument("--tools", type=int, default=3)
    ap.add_argument("--start-timeout", type=float, default=START_TIMEOUT, help="seconds (%(default)s)")
    ap.add_argument("--recover-timeout", type=float, default=RECOVER_TIMEOUT, help="seconds (%(default)s)")
    ap.add_argument(
        "--type-lookup",
        choices=("off", "on"),
        default="off",
        help="on: the bridge's ROS 2 participant keeps Fast DDS's type lookup (to compare)",
    )
    ap.add_argument(
        "--cyclone-uri",
        default="",
        help="CYCLONEDDS_URI for every paramdds process (an empty IgnoreTypeInformation "
        "element there brings back the behaviour that broke ROS 2, to compare)",
    )
    ap.add_argument("-o", "--output", choices=("table", "json"), default="table")
    args = ap.parse_args(argv)
    if args.mode == "tool":
        print(json.dumps(_tool_main(args.fqn, args.timeout)), flush=True)
        return 0
    result = run(args)
    if args.output == "json":
        print(json.dumps(result, indent=2))
    else:
        print(table(result))
    return 0 if ok(result) else 1


def _span(stats: dict[str, Any]) -> str:
    return f"min {stats['min']} s, median {stats['median']} s, max {stats['max']} s"


def table(result: dict[str, Any]) -> str:
    """The result as lines of text."""
    start = result["start"]
    lines = [
        f"{result['nodes']} nodes in {result['hosts']} host processes"
        + (
            f", {result['unknown_per_node']} publishers of unknown types each"
            if result["unknown_per_node"]
            else ""
        )
        + f"; the bridge's type lookup {result['type_lookup']}"
        + (
            f"; starved: {result['starved']['stops']:g} stops, {result['starved']['seconds']:g} s"
            if result["starved"]
            else ""
        ),
        f"bridges dead: {len(result['dead'])} of {result['starts']}"
        + "".join(f"\n  start {d['start']} ({d['when']}): exit {d['exit']}" for d in result["dead"]),
        f"starts complete: {start['complete']} of {result['starts']}; start to all mirrored: {_span(start)}",
    ]
    for seconds, stats in result["stalls"].items():
        lines.append(
            f"stall {seconds} s: every node mirrored again after {stats['complete']} of "
            f"{len(stats['seconds'])} stalls; "
            f"nodes shown not mirrored during each: {stats.get('noticed', [])}; "
            f"SIGCONT to all mirrored: {_span(stats)}"
            + (f"; of which the bridge ran: {_span(stats['bridge_ran'])}" if stats.get("bridge_ran") else "")
        )
    if result["unmirrored"]:
        lines.append(
            "nodes not mirrored: "
            + ", ".join(f"{u['missing']} (start {u['start']}, {u['when']})" for u in result["unmirrored"])
        )
    if result["tools"]:
        reached = [t["reached"] for t in result["tools"]]
        lines.append(f"fresh rclpy tools reached {reached} of {result['nodes']} nodes")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
