"""ROS 2 and paramdds on one domain id: ``python -m tests.support.ros2_shared`` (from the checkout).

Real processes on one domain id (ROS 2's ``ROS_DOMAIN_ID`` and paramdds's the same number),
loopback only: one rclpy host process (the nodes of ``--params-file``, default the nav2
file of ``realworld/``, or ``--nodes N`` synthetic nodes), a ``paramdds server``, a
``paramdds watch`` (a monitor), and a monitor in this process. Then:

* ``--starts`` bridge starts: ``paramdds ros2`` mirroring the host's nodes, timed from its
  start until this process's monitor holds every node mirrored (online, complete, origin
  ``ros2``), then stopped (SIGTERM), and the next start waits until every mirror is offline;
* ``--tools`` fresh rclpy processes (what ``ros2 param list`` does: learn the graph, then
  a parameter client per node) that list the parameters of every node, with the bridge
  of the last start still up.

Prints the time from each start to all nodes mirrored (min / median / max) and how many
nodes each tool reached. No Cyclone discovery tag may be set (``CYCLONEDDS_URI`` is
dropped): Fast DDS knows no tags, and with one Cyclone would not meet ROS 2 at all.
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
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from statistics import median
from typing import Any

from tests.support.realworld import ROOT, find_realworld

START_TIMEOUT = 60.0  # seconds a bridge start may take to mirror every node before it counts as failed
TOOL_TIMEOUT = 30.0


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


@contextmanager
def shared_domain(env: dict[str, str], host_args: Sequence[str]) -> Iterator[list[str]]:
    """The rclpy host (``paramdds.bench.ros2_host`` with ``host_args``), a paramdds server and a
    ``paramdds watch`` on the domain of ``env``; yields the host's nodes (``/ns/name``)."""
    procs: list[_Proc] = []
    try:
        host = _Proc(_python("-m", "paramdds.bench.ros2_host", *host_args), env, ready="ready")
        procs.append(host)
        server_args = ("-m", "paramdds.cli", "server", "-n", "shared_domain_probe", "--use-sim-time")
        procs.append(_Proc(_python(*server_args), env, ready="[SERVER] Serving"))
        procs.append(_Proc(_python("-m", "paramdds.cli", "watch"), env))
        yield host.first.split()[1:]
    finally:
        for p in reversed(procs):
            p.stop()


def mirrored(monitor: Any, nodes: Sequence[str]) -> int:
    """How many of ``nodes`` the monitor holds mirrored: online, complete, origin ``ros2``."""
    snap = monitor.snapshot()
    return sum(
        1
        for n in nodes
        if (st := snap.get(n.lstrip("/"))) is not None and st.online and st.complete and st.origin == "ros2"
    )


def diagnosis(monitor: Any, nodes: Sequence[str], bridge: _Proc) -> str:
    """Why a start is incomplete: what the monitor holds of ``nodes`` and the bridge's state."""
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


def run(args: argparse.Namespace) -> dict[str, Any]:
    from paramdds.dds.monitor import ParameterMonitor
    from paramdds.dds.participant import close_participant, make_participant

    host_args: list[str] = []
    if args.nodes:
        host_args = [a for i in range(args.nodes) for a in ("--node", f"/shared/n{i:03d}")]
        glob = "/shared/*"
    else:
        where = find_realworld()
        path = Path(args.params_file) if args.params_file else (where / "nav2_params.yaml" if where else None)
        if path is None or not path.is_file():
            raise SystemExit("no parameter file: give --params-file, or --nodes N")
        host_args = ["--params-file", str(path)]
        glob = "*"
    with tempfile.TemporaryDirectory(prefix="paramdds-ros2-shared-") as tmp:
        env = shared_env(args.domain, Path(tmp))
        os.environ.pop("CYCLONEDDS_URI", None)
        if args.cyclone_uri:
            env["CYCLONEDDS_URI"] = os.environ["CYCLONEDDS_URI"] = args.cyclone_uri
        with shared_domain(env, host_args) as nodes:
            dp = make_participant(args.domain, localhost=True)
            monitor = ParameterMonitor(dp)
            times: list[float | None] = []
            tools: list[dict[str, Any]] = []
            bridge = None
            try:
                for i in range(args.starts):
                    if bridge is not None:
                        stop_bridge(bridge, monitor, nodes)
                    took, bridge = bridge_start(env, nodes, monitor, glob=glob, timeout=args.start_timeout)
                    times.append(took)
                    print(f"start {i + 1}: {took if took is not None else 'INCOMPLETE'} s", file=sys.stderr)
                for _ in range(args.tools):
                    tools.append(tool(env, nodes))
            finally:
                if bridge is not None:
                    bridge.stop()
                monitor.close()
                close_participant(dp)
    done = [t for t in times if t is not None]
    return {
        "nodes": len(nodes),
        "starts": len(times),
        "complete": len(done),
        "seconds": times,
        "min": min(done) if done else None,
        "median": round(median(done), 2) if done else None,
        "max": max(done) if done else None,
        "tools": tools,
    }


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
    ap.add_argument("--starts", type=int, default=10)
    ap.add_argument("--tools", type=int, default=3)
    ap.add_argument("--start-timeout", type=float, default=START_TIMEOUT, help="seconds (%(default)s)")
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
        print(
            f"{result['nodes']} nodes, {result['complete']} of {result['starts']} bridge starts complete; "
            f"start to all mirrored: min {result['min']} s, median {result['median']} s, "
            f"max {result['max']} s; fresh rclpy tools reached "
            f"{[t['reached'] for t in result['tools']]} of {result['nodes']} nodes"
        )
    return 0 if result["complete"] == result["starts"] else 1


if __name__ == "__main__":
    sys.exit(main())
