"""``paramdds bench scaling``: a late monitor's time to the full state of N nodes.

For each N, both systems host N nodes x P parameters in the same number of server
processes (``--servers``, default 2), each node an ordinary core
:class:`~paramdds.core.table.ParameterTable`:

* paramdds: one :class:`~paramdds.dds.server.ParameterServer` per process on the
  seven global topics; the monitor is one :class:`~paramdds.dds.monitor.ParameterMonitor`
  (one TRANSIENT_LOCAL reader) waiting until every node is complete;
* baseline: the ROS 2 layout (rmw_cyclonedds names: ``rq/<node>/<service>Request``,
  ``rr/<node>/<service>Reply`` for the six parameter services, one shared
  ``rt/parameter_events``), served by the same tables; its monitor does what
  ``ros2 param dump`` does for every node — clients for list, get and describe,
  wait for them to match, list, then get + describe — with every node in flight
  at once (see :class:`~paramdds.bench._dds.RosLayoutMonitor`).

The two systems live in neighbouring domains (``-d`` and the next one) so both
can stay up and the monitors alternate (paramdds, baseline, paramdds, …) without
one system's discovery traffic reaching the other's monitor. The timed span starts
when the monitor's participant exists (imports excluded); the process time is
from spawning the monitor until it reports. Topics and endpoints are counted from
the builtin topics (``DCPSTopic`` with topic discovery on in the servers and the
census participant; ``DCPSPublication`` / ``DCPSSubscription`` for endpoints).
"""

from __future__ import annotations

import argparse

from ._common import Worker, Workers, emit, median, note, render

DEFAULT_NODES = (10, 50, 100, 200)


def _start_servers(
    workers: Workers, layout: str, nodes: int, params: int, servers: int, domain: int
) -> list[Worker]:
    started = []
    per = -(-nodes // servers)
    offset = 0
    while offset < nodes:
        count = min(per, nodes - offset)
        started.append(
            workers.start(
                "server",
                "--layout",
                layout,
                "--nodes",
                str(count),
                "--offset",
                str(offset),
                "--params",
                str(params),
                "--topic-discovery",
                domain=domain,
            )
        )
        offset += count
    return started


def _monitor(workers: Workers, layout: str, nodes: int, domain: int) -> dict[str, float]:
    w = workers.start("monitor", "--layout", layout, "--nodes", str(nodes), "--timeout", "90", domain=domain)
    try:
        result = w.read("RESULT", 120)
    finally:
        workers.stop(w)
    result["process_ms"] = (result["_at_ns"] - w.started_ns) / 1e6
    return result


def run(args: argparse.Namespace) -> int:
    counts = args.nodes or ([5, 20] if args.quick else list(DEFAULT_NODES))
    params = args.params or 50
    servers = args.servers or 2
    ours_domain = args.domain
    base_domain = args.domain + 1 if args.domain < 232 else args.domain - 1
    rows = []
    with Workers(localhost=args.localhost, domain=ours_domain) as workers:
        for n in counts:
            note(f"scaling: {n} nodes x {params} params in {min(servers, n)} server processes per system")
            group = _start_servers(workers, "paramdds", n, params, servers, ours_domain)
            group += _start_servers(workers, "ros", n, params, servers, base_domain)
            for w in group:
                w.read("READY", 180)
            # the baseline at 200+ nodes takes ~15 s a run: one run there keeps the default under ~2 min
            reps = args.rounds or (1 if args.quick or n > 100 else 3)
            runs: dict[str, list[dict[str, float]]] = {"paramdds": [], "ros": []}
            for _ in range(reps):
                for layout, domain in (("paramdds", ours_domain), ("ros", base_domain)):
                    result = _monitor(workers, layout, n, domain)
                    if result["params"] != n * params:
                        raise RuntimeError(
                            f"{layout} monitor got {result['params']} of {n * params} parameters"
                        )
                    runs[layout].append(result)
            census = {}
            for layout, domain in (("paramdds", ours_domain), ("ros", base_domain)):
                c = workers.start("census", domain=domain)
                census[layout] = c.read("RESULT", 60)
                workers.stop(c)
            for w in group:
                workers.stop(w)

            def med(layout: str, key: str, runs: dict[str, list[dict[str, float]]] = runs) -> float:
                return round(median([r[key] for r in runs[layout]]), 1)

            rows.append(
                {
                    "nodes": n,
                    "paramdds_full_state_ms": med("paramdds", "full_state_ms"),
                    "baseline_full_state_ms": med("ros", "full_state_ms"),
                    "paramdds_process_ms": med("paramdds", "process_ms"),
                    "baseline_process_ms": med("ros", "process_ms"),
                    "paramdds_topics": census["paramdds"]["topics"],
                    "baseline_topics": census["ros"]["topics"],
                    "paramdds_monitor_endpoints": int(med("paramdds", "endpoints")),
                    "baseline_monitor_endpoints": int(med("ros", "endpoints")),
                    "paramdds_endpoints": census["paramdds"]["endpoints"],
                    "baseline_endpoints": census["ros"]["endpoints"],
                    "ratio_full_state": round(
                        med("ros", "full_state_ms") / med("paramdds", "full_state_ms"), 1
                    ),
                    "parameters": n * params,
                    "repetitions": reps,
                }
            )
    table = render(
        [
            "nodes",
            "params",
            "full state ms",
            "baseline ms",
            "x",
            "process ms",
            "baseline",
            "topics",
            "baseline",
            "monitor endpoints",
            "baseline",
        ],
        [
            (
                r["nodes"],
                r["parameters"],
                r["paramdds_full_state_ms"],
                r["baseline_full_state_ms"],
                r["ratio_full_state"],
                r["paramdds_process_ms"],
                r["baseline_process_ms"],
                r["paramdds_topics"],
                r["baseline_topics"],
                r["paramdds_monitor_endpoints"],
                r["baseline_monitor_endpoints"],
            )
            for r in rows
        ],
    )
    table += (
        "\n\nmedian of the repetitions (3 up to 100 nodes, 1 above, or --rounds); "
        f"servers per system: {servers}; "
        f"domains {ours_domain} (paramdds) and {base_domain} (ROS 2 layout baseline)"
    )
    emit(args, {"rows": rows, "servers": servers, "params": params}, table)
    return 0
