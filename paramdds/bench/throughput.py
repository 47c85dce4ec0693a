"""``paramdds bench throughput``: single-parameter gets per second with many in flight.

One server process hosts one node; ``--clients`` client processes (default 2) each
run ``--window`` asyncio tasks (default 16) that await one
:meth:`AsyncParameterClient.get` after another, for ``--seconds`` (default 3) after
a warm-up. The raw echo baseline runs the same way: the same number of client
processes and tasks, each awaiting an echo of the get's payload sizes through the
same Future → asyncio path, against a separate echo process. The two alternate in
rounds (``--rounds``, default 3); the median round is reported.
"""

from __future__ import annotations

import argparse
from typing import Any

from ._common import Workers, emit, median, node_names, note, render
from ._dds import get_sizes
from .worker import param_name, value_for

NODE = node_names(1)[0]
lost: dict[str, int] = {}  # unanswered requests by kind, over the whole run


def _round(
    workers: Workers, kind: str, clients: int, window: int, seconds: float, warmup: float, req_size: int
) -> float:
    loads = [
        workers.start(
            "load",
            "--kind",
            kind,
            "--node",
            NODE,
            "--window",
            str(window),
            "--seconds",
            str(seconds),
            "--warmup",
            str(warmup),
            "--request-size",
            str(req_size),
        )
        for _ in range(clients)
    ]
    try:
        for w in loads:
            w.read("READY", 60)
        for w in loads:
            w.send("go")
        results = [w.read("RESULT", seconds + warmup + 60) for w in loads]
        lost[kind] = lost.get(kind, 0) + sum(int(r.get("lost", 0)) for r in results)
        return float(sum(r["per_s"] for r in results))
    finally:
        for w in loads:
            workers.stop(w)


def run(args: argparse.Namespace) -> int:
    clients = args.clients or 2
    window = args.window or 16
    seconds = args.seconds or (1.0 if args.quick else 3.0)
    warmup = 0.3 if args.quick else 1.0
    rounds = args.rounds or (1 if args.quick else 3)
    req_size, rep_size = get_sizes(NODE, param_name(0), value_for(0))
    gets: list[float] = []
    raws: list[float] = []
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        server = workers.start("server", "--nodes", "1", "--params", "50")
        echo = workers.start("echo", "--reply-size", str(rep_size))
        server.read("READY", 60)
        echo.read("READY", 60)
        note(f"throughput: {clients} client processes x {window} in flight, {rounds} rounds of {seconds:g} s")
        for r in range(rounds):
            order = ("get", "echo") if r % 2 == 0 else ("echo", "get")
            for kind in order:
                rate = _round(workers, kind, clients, window, seconds, warmup, req_size)
                (gets if kind == "get" else raws).append(rate)
    data: dict[str, Any] = {
        "gets_per_s": round(median(gets), 0),
        "raw_per_s": round(median(raws), 0),
        "ratio_get_raw": round(median(gets) / median(raws), 3),
        "clients": clients,
        "window": window,
        "seconds": seconds,
        "rounds": rounds,
        "lost_gets": lost.get("get", 0),
        "lost_echoes": lost.get("echo", 0),
        "gets_per_s_rounds": [round(g) for g in gets],
        "raw_per_s_rounds": [round(g) for g in raws],
    }
    table = render(
        ["system", "per second (median)", "rounds"],
        [
            ("get (1 param)", data["gets_per_s"], " ".join(str(v) for v in data["gets_per_s_rounds"])),
            ("raw echo", data["raw_per_s"], " ".join(str(v) for v in data["raw_per_s_rounds"])),
        ],
    )
    table += f"\n\n{clients} client processes x {window} in flight; get / raw = {data['ratio_get_raw']}"
    emit(args, data, table)
    return 0
