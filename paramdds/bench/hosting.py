"""``paramdds bench hosting``: one process hosting many node ids.

One server process hosts ``--nodes`` node ids (default 1000) x ``--params``
parameters (default 20). Reported: the start time (spawn until it serves; also
the part after imports), its resident memory (VmRSS from /proc, the larger of
the readings after start and after the monitors), and a late monitor process's
time from its participant until it holds all N x P parameters (median of
``--rounds``, default 3).
"""

from __future__ import annotations

import argparse

from ._common import Workers, emit, median, note, render, rss_mb


def run(args: argparse.Namespace) -> int:
    nodes = (args.nodes or [200 if args.quick else 1000])[0]
    params = args.params or 20
    reps = args.rounds or (1 if args.quick else 3)
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        note(f"hosting: {nodes} node ids x {params} params in one process")
        server = workers.start("server", "--nodes", str(nodes), "--params", str(params))
        ready = server.read("READY", 180)
        start_ms = (ready["_at_ns"] - server.started_ns) / 1e6
        rss = [rss_mb(server.pid)]
        runs = []
        for _ in range(reps):
            mon = workers.start("monitor", "--nodes", str(nodes), "--timeout", "60")
            result = mon.read("RESULT", 90)
            workers.stop(mon)
            if result["params"] != nodes * params:
                raise RuntimeError(f"the monitor got {result['params']} of {nodes * params} parameters")
            result["process_ms"] = (result["_at_ns"] - mon.started_ns) / 1e6
            runs.append(result)
            rss.append(rss_mb(server.pid))
    data = {
        "nodes": nodes,
        "params_per_node": params,
        "parameters": nodes * params,
        "rss_mb": round(max(rss), 1),
        "rss_after_start_mb": round(rss[0], 1),
        "start_ms": round(start_ms, 1),
        "start_after_import_ms": round(ready["setup_ms"], 1),
        "full_state_ms": round(median([r["full_state_ms"] for r in runs]), 1),
        "monitor_process_ms": round(median([r["process_ms"] for r in runs]), 1),
        "rounds": reps,
    }
    table = render(
        ["figure", "value"],
        [
            ("node ids x params", f"{nodes} x {params} = {nodes * params}"),
            ("server start (spawn → serving), ms", data["start_ms"]),
            ("  of which after imports, ms", data["start_after_import_ms"]),
            ("server RSS, MB", data["rss_mb"]),
            ("monitor full state (from participant), ms", data["full_state_ms"]),
            ("monitor whole process, ms", data["monitor_process_ms"]),
        ],
    )
    emit(args, data, table)
    return 0
