"""``paramdds bench ros2``: real ROS 2 (rclpy on Fast DDS, from PyPI) against paramdds.

The same parameter sets (the nodes of the parameter files in ``realworld/``, one set
per node in turn, plus one double ``bench_gain`` for the warm sets) are hosted by
``--servers`` host processes (default 4) in each system: ``python -m
paramdds.bench.ros2_host`` (rclpy nodes, single-threaded executor) and ``paramdds server``.
For each N of ``--nodes`` (default 10, 100, 300), both systems' hosts run side by side
(each on its own domain id) and:

* ``state``: whole-process time of a fresh process that holds every node's parameters
  and descriptors: rclpy waits for the N nodes in its graph (it is told N), then lists,
  gets and describes all of them concurrently; paramdds starts a monitor until all
  are complete. Median of ``--rounds`` that alternate between the two systems (the
  order flipped every round), so both are measured under the same load;
* ``get``: whole-process time of one fresh get (an rclpy AsyncParameterClient; ``paramdds
  get``), median of ``--rounds``;
* ``warm get / set``: p50 and p99 over ``--requests`` calls to one node from one process;
* ``graph``: topics (+ services for ROS 2), endpoints, DDS participants;
* ``kill -9`` (with two hosts or more): a host killed 0.3 s after a fresh state process
  started: how long that process takes and how many nodes it got. The rclpy process cannot
  know a host died: it waits until no new node appeared for 2 s, then for each node in its
  graph (the dead host's stay there for Fast DDS's 20 s lease) up to its 5 s timeout;
  paramdds sees the dead host's nodes offline within its 1 s lease, or never sees them;
* ``bridge``: ``paramdds ros2`` started beside the rclpy system: time from its start
  until a fresh paramdds process holds all N mirrored nodes; then warm gets and sets of
  one mirrored node through it (``--requests``), beside rclpy's own warm calls.

ROS 2 runs on ``ROS_DOMAIN_ID`` (a random one when unset), loopback only over UDP.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

from ._common import emit, finish_timed, median, note, percentile, render, run_timed, start_timed

PREFIX = "bench_n"
ROS_NS = "bench"
KILL_AFTER = 0.3  # seconds after the state process starts
ROS_NODE_TIMEOUT = 5.0  # the rclpy dump's timeout per node
QUIET = 2.0  # with a host killed, the rclpy dump stops waiting for nodes after this long without a new one


def find_realworld() -> Path | None:
    """The real parameter files: ``$PARAMDDS_REALWORLD``, else ``shared/realworld`` beside the
    checkout (``../shared``) or beside the directory of worktrees (``../../shared``)."""
    given = os.environ.get("PARAMDDS_REALWORLD")
    root = Path(__file__).resolve().parents[2]
    for candidate in (
        [Path(given)]
        if given
        else [root.parent / "shared" / "realworld", root.parent.parent / "shared" / "realworld"]
    ):
        if candidate.is_dir():
            return candidate
    return None


def realworld_sets(where: Path) -> list[dict[str, Any]]:
    """The ``ros__parameters`` of every node in the parameter files under ``where``."""
    sets: list[dict[str, Any]] = []

    def walk(doc: object) -> None:
        if isinstance(doc, dict):
            for key, sub in doc.items():
                if key == "ros__parameters" and isinstance(sub, dict) and sub:
                    sets.append(_valid(sub))
                else:
                    walk(sub)

    for path in sorted(where.glob("*.yaml")):
        text = path.read_text()
        if "ros__parameters" in text:
            walk(yaml.safe_load(text))
    return sets


def _valid(params: dict[str, Any]) -> dict[str, Any]:
    """``params`` without the names paramdds refuses (both systems get the same set): in
    these files only ``$(var tf_prefix)…``, a launch substitution left in a file."""
    from ..core.names import is_valid_name

    return {
        k: _valid(v) if isinstance(v, dict) else v
        for k, v in params.items()
        if is_valid_name(str(k)) and (not isinstance(v, dict) or _valid(v))
    }


def host_files(tmp: Path, n: int, hosts: int, sets: list[dict[str, Any]]) -> list[tuple[Path, list[str]]]:
    """One ROS 2 parameter file per host, and its nodes (``bench/bench_n0000``...)."""
    out = []
    for h in range(hosts):
        nodes = [f"{ROS_NS}/{PREFIX}{i:04d}" for i in range(h, n, hosts)]
        doc = {
            f"/{node}": {"ros__parameters": {**sets[i % len(sets)], "bench_gain": 1.0}}
            for node, i in zip(nodes, range(h, n, hosts), strict=True)
        }
        path = tmp / f"n{n}_host{h}.yaml"
        path.write_text(yaml.dump(doc, Dumper=_NoAliases, sort_keys=False))  # rcl refuses aliases
        out.append((path, nodes))
    return out


class _NoAliases(yaml.SafeDumper):
    def ignore_aliases(self, data: Any) -> bool:
        return True


class Host:
    """A host process that prints a line when its nodes are up and stops on stdin EOF / SIGINT."""

    def __init__(self, cmd: list[str], env: dict[str, str], ready: str, lines: int = 1) -> None:
        self.proc = subprocess.Popen(
            cmd,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
            start_new_session=True,
        )
        assert self.proc.stdout is not None
        seen = 0
        deadline = time.monotonic() + 120
        while seen < lines and time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError(f"{cmd[:4]} exited before it was ready")
            seen += line.startswith(ready)

    def stop(self) -> None:
        if self.proc.poll() is None:
            try:
                assert self.proc.stdin is not None
                self.proc.stdin.write("quit\n")
                self.proc.stdin.close()
            except OSError:
                pass
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait()


def _probe_cmd(mode: str, args: tuple[object, ...]) -> list[str]:
    return [sys.executable, "-m", "paramdds.bench._ros2_probe", mode, *map(str, args)]


def _probe_result(out: str) -> dict[str, Any]:
    """A probe's result: the JSON object on its last line of output."""
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    return result


def probe(
    mode: str, *args: object, env: dict[str, str], timeout: float = 180.0
) -> tuple[float, dict[str, Any]]:
    ms, out = run_timed(_probe_cmd(mode, args), env=env, timeout=timeout)
    return ms, _probe_result(out)


def killed_during(mode: str, host: Host, *args: object, env: dict[str, str]) -> tuple[float, dict[str, Any]]:
    """A fresh state process, with ``host`` killed -9 KILL_AFTER seconds after it started."""
    proc, t0 = start_timed(_probe_cmd(mode, args), env=env)
    time.sleep(KILL_AFTER)
    host.kill()
    ms, out = finish_timed(proc, t0, timeout=180)  # a probe still running then is killed
    return ms, _probe_result(out)


def stats(samples: list[float]) -> dict[str, float]:
    return {"p50": round(percentile(samples, 50), 3), "p99": round(percentile(samples, 99), 3)}


def warm_stats(system: str, warm: dict[str, list[float]]) -> dict[str, dict[str, float]]:
    """The row's ``{system}_warm_get`` and ``_set`` percentiles from a warm probe's samples."""
    return {f"{system}_warm_{kind}": stats(warm[f"{kind}_ms"]) for kind in ("get", "set")}


def ros_env(tmp: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("ROS_DOMAIN_ID", str(random.randint(1, 99)))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["FASTDDS_BUILTIN_TRANSPORTS"] = "UDPv4"
    env["ROS_LOG_DIR"] = str(tmp / "roslog")
    env["PARAMDDS_LOCALHOST"] = "1"
    env.setdefault("PYTHONUNBUFFERED", "1")
    return env


def run(args: argparse.Namespace) -> int:
    from ..ros2 import missing

    reason = missing()
    if reason:
        note(f"skipped: {reason}")
        emit(args, {"skipped": reason}, f"ros2: skipped: {reason}")
        return 0
    where = find_realworld()
    sets = realworld_sets(where) if where is not None else []
    if not sets:
        raise SystemExit(
            "bench ros2: no real parameter files found (set PARAMDDS_REALWORLD to their directory)"
        )
    counts = args.nodes or ([10] if args.quick else [10, 100, 300])
    hosts = args.servers or 4
    requests = args.requests or (100 if args.quick else 1000)
    rounds = args.rounds or (1 if args.quick else 5)
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="paramdds-bench-ros2-") as tmpdir:
        tmp = Path(tmpdir)
        env = ros_env(tmp)
        for i, n in enumerate(counts):
            row = measure(
                n, hosts, host_files(tmp, n, hosts, sets), env, args, requests, rounds, args.domain + 1 + i
            )
            rows.append(row)
    data = {"hosts": hosts, "parameter_sets": len(sets), "ros_domain": env["ROS_DOMAIN_ID"], "rows": rows}
    emit(args, data, table(rows, hosts, len(sets)))
    return 0


def measure(
    n: int,
    hosts: int,
    files: list[tuple[Path, list[str]]],
    env: dict[str, str],
    args: argparse.Namespace,
    requests: int,
    rounds: int,
    bridge_domain: int,
) -> dict[str, Any]:
    """One N: both systems' hosts run side by side (ROS 2 on its domain, paramdds on ``-d``),
    the fresh-process state rounds alternate between them, then each system's other rows."""
    node0 = f"{ROS_NS}/{PREFIX}0000"
    domain = str(args.domain)
    row: dict[str, Any] = {"nodes": n}
    ros: list[Host] = []
    servers: list[Host] = []
    try:
        note(f"N={n}: ROS 2 hosts and paramdds servers")
        ros = [ros_host(f, env) for f, _ in files]
        servers = [dds_server(f, nodes, domain, env) for f, nodes in files]
        # the headline rows: alternate rounds (the order flipped every round), so both
        # systems are measured under the same load, in the same minutes
        ros_dumps: list[tuple[float, dict[str, Any]]] = []
        dds_dumps: list[tuple[float, dict[str, Any]]] = []
        for r in range(rounds):
            order = ("ros", "dds") if r % 2 == 0 else ("dds", "ros")
            for system in order:
                if system == "ros":
                    ros_dumps.append(
                        probe("ros-dump", n, f"/{ROS_NS}/{PREFIX}", ROS_NODE_TIMEOUT, 0, env=env)
                    )
                else:
                    dds_dumps.append(probe("dds-dump", n, f"{ROS_NS}/{PREFIX}", 60, domain, env=env))
        row["params"] = ros_dumps[0][1]["params"]
        row["ros_state_ms"] = median([d[0] for d in ros_dumps])
        row["ros_complete"] = min(d[1]["complete"] for d in ros_dumps)
        row["ros_graph"] = {
            k: ros_dumps[0][1][k] for k in ("topics", "services", "endpoints", "participants")
        }
        row["dds_state_ms"] = median([d[0] for d in dds_dumps])
        row["dds_complete"] = min(d[1]["complete"] for d in dds_dumps)
        # -- real ROS 2 ----------------------------------------------------------------
        row["ros_get_ms"] = median(
            [probe("ros-get", "/" + node0, "bench_gain", env=env)[0] for _ in range(rounds)]
        )
        warm = probe("ros-warm", "/" + node0, "bench_gain", requests, env=env)[1]
        row.update(warm_stats("ros", warm))
        note(f"N={n}: the bridge")
        row.update(bridge_rows(n, env, args, bridge_domain, node0, requests))
        # -- paramdds ------------------------------------------------------------------
        get = [sys.executable, "-m", "paramdds.cli", "get", "-d", domain, "--localhost", node0, "bench_gain"]
        row["dds_get_ms"] = median([run_timed(get, env=env)[0] for _ in range(rounds)])
        warm = probe("dds-warm", node0, "bench_gain", requests, domain, env=env)[1]
        row.update(warm_stats("dds", warm))
        row["dds_graph"] = probe("dds-graph", domain, env=env)[1]
        # -- a host killed: last, each system's own; with one host there is nothing left to
        # hold, and each probe would only wait out its timeout (a minute each)
        if hosts < 2:
            note(f"N={n}: state with a host killed: not measured with one host")
        else:
            note(f"N={n}: state with a host killed")
            ms, out = killed_during(
                "ros-dump", ros[0], n, f"/{ROS_NS}/{PREFIX}", ROS_NODE_TIMEOUT, QUIET, env=env
            )
            row["ros_kill_ms"], row["ros_kill_complete"] = ms, out["complete"]
            ms, out = killed_during("dds-dump", servers[0], n, f"{ROS_NS}/{PREFIX}", 60, domain, env=env)
            row["dds_kill_ms"], row["dds_kill_complete"] = ms, out["complete"]
    finally:
        for h in [*ros, *servers]:
            h.stop()
    row["state_speedup"] = round(row["ros_state_ms"] / row["dds_state_ms"], 1)
    return row


def ros_host(params_file: Path, env: dict[str, str]) -> Host:
    """An rclpy host process of the nodes of ``params_file`` (one single-threaded executor)."""
    cmd = [
        sys.executable,
        "-m",
        "paramdds.bench.ros2_host",
        "--params-file",
        str(params_file),
        "--threads",
        "1",
    ]
    return Host(cmd, env, "ready")


def dds_server(params_file: Path, nodes: list[str], domain: str, env: dict[str, str]) -> Host:
    """A ``paramdds server`` of ``nodes``, each with the parameters of ``params_file``."""
    cmd = [
        sys.executable,
        "-m",
        "paramdds.cli",
        "server",
        "-d",
        domain,
        "--localhost",
        "-p",
        str(params_file),
    ]
    return Host([*cmd, *(a for node in nodes for a in ("-n", node))], env, "[SERVER] Serving", len(nodes))


def bridge_rows(
    n: int, env: dict[str, str], args: argparse.Namespace, domain: int, node: str, requests: int
) -> dict[str, Any]:
    """``paramdds ros2`` started beside the rclpy system: the time from its start until a fresh
    paramdds process holds all N mirrors, then warm gets and sets of ``node`` through it (a
    paramdds client, the bridge, the rclpy node's services, and back)."""
    t0 = time.perf_counter()
    bridge = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "paramdds.cli",
            "ros2",
            "-d",
            str(domain),
            "--localhost",
            "--mirror",
            f"/{ROS_NS}/*",
            "--resync",
            "0",
        ],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    try:
        probe("dds-dump", n, f"{ROS_NS}/{PREFIX}", 120, domain, env=env)
        took = round((time.perf_counter() - t0) * 1e3, 1)
        warm = probe("dds-warm", node, "bench_gain", requests, domain, env=env)[1]
        return {"bridge_ms": took, **warm_stats("bridge", warm)}
    finally:
        bridge.send_signal(signal.SIGINT)
        try:
            bridge.wait(timeout=20)
        except subprocess.TimeoutExpired:
            bridge.kill()
            bridge.wait()


def table(rows: list[dict[str, Any]], hosts: int, sets: int) -> str:
    lines = [
        f"real ROS 2 (rclpy, Fast DDS) vs paramdds: {hosts} host processes each, {sets} real parameter sets"
    ]
    heads = ["N", "params", "measure", "ROS 2", "paramdds", "ratio"]
    body: list[list[object]] = []
    for r in rows:
        n, p = r["nodes"], r["params"]

        def add(what: str, a: float, b: float, n: int = n, p: int = p) -> None:
            body.append([n, p, f"{what} (ms)", round(a, 2), round(b, 2), f"{a / b:.1f}x" if b else "-"])

        add("state, fresh process", r["ros_state_ms"], r["dds_state_ms"])
        add("get, fresh process", r["ros_get_ms"], r["dds_get_ms"])
        for kind in ("get", "set"):
            for q in ("p50", "p99"):
                add(f"warm {kind} {q}", r[f"ros_warm_{kind}"][q], r[f"dds_warm_{kind}"][q])
        g, d = r["ros_graph"], r["dds_graph"]
        body.append([n, p, "topics (+ services)", f"{g['topics']} + {g['services']}", d["topics"], "-"])
        body.append(
            [n, p, "endpoints", g["endpoints"], d["endpoints"], f"{g['endpoints'] / d['endpoints']:.0f}x"]
        )
        body.append([n, p, "participants", g["participants"], d["participants"], "-"])
        if "ros_kill_ms" in r:  # two hosts or more
            add(
                f"state, host killed ({r['ros_kill_complete']} / {r['dds_kill_complete']} nodes)",
                r["ros_kill_ms"],
                r["dds_kill_ms"],
            )
        body.append([n, p, "bridge: start -> fresh client holds all (ms)", "-", r["bridge_ms"], "-"])
        for kind in ("get", "set"):  # the ROS 2 column: rclpy's own warm calls to the same node
            for q in ("p50", "p99"):
                add(
                    f"warm {kind} {q} through the bridge",
                    r[f"ros_warm_{kind}"][q],
                    r[f"bridge_warm_{kind}"][q],
                )
    return "\n".join(lines) + "\n" + render(heads, body)
