"""``paramdds bench SCENARIO``: its arguments and the scenario table; the scenarios live in
:mod:`paramdds.bench` (one module each, ``run(args) -> int``), each printing a table, or one
JSON object with ``-o json``.
"""

from __future__ import annotations

import argparse

from .._argtypes import positive_float, positive_int

HELP = "benchmarks (see 'paramdds bench --help')"

SCENARIOS = {
    "latency": "round trip of a get and of a set of 10 vs a raw echo and a 10 ms polling client",
    "scaling": "monitor time to full state of N nodes x 50 params vs the ROS 2 per-node service layout",
    "throughput": "gets per second with many requests in flight vs a raw echo",
    "hosting": "one process hosting 1,000 node ids x 20 params: start time, RSS, monitor full state",
    "startup": "whole-process time of `paramdds get` vs `import cyclonedds` and a bare participant",
    "codec": "encode/decode per sample (CPU time), paramdds's codecs vs the binding's interpreter",
    "web": "browser console in headless Chromium: set ack → value in the DOM; first render of 1000 x 50",
    "fleet": "10 server processes x 1,000 nodes x 20 params: monitor synced, `paramdds get` vs an empty "
    "system, a server's CPU under foreign traffic (native filter vs handler), loopback bytes per request",
    "persist": "sets/s with --persist at 10 and 1,000 params, 1 and 8 clients, vs without; "
    "restart from a 100k-change journal",
    "history-store": "where --persist keeps history: the journal vs SQLite (WAL): µs per durable change, "
    "queries at 1M records, recovery after kill -9",
    "schema": "a set on the node of the largest Autoware JSON Schema vs the equivalent spec node; "
    "paramdds check --autoware on every realworld pair",
    "zenoh": "sites behind Zenoh gateways: fresh remote client holds every node, remote get/set vs "
    "direct DDS, uplink bytes per change with 1 and 10 viewers, vs one stretched DDS domain (zenoh extra)",
    "ros2": "real ROS 2 (rclpy from PyPI) vs paramdds at N = 10, 100, 300 real nodes: fresh state, "
    "fresh get, warm get/set, graph size, a host killed, the bridge (needs the ros2 extra)",
    "foxglove": "a Foxglove client's get-all at 100, 1,000, 10,000 nodes x 20 params and change-to-client "
    "latency (paramdds foxglove) vs foxglove_bridge's way over rclpy nodes (foxglove extra)",
    "record": "paramdds record: its CPU and bytes per change at 10, 100, 1,000 changes/s, "
    "vs paramdds watch following the same changes (foxglove extra)",
    "soak": "one site under churn for --minutes (50 nodes in 5 restarted servers, clients, monitors, web, "
    "Zenoh, ROS 2 bridge): RSS, threads, fds of each long-lived process; lost writes; wrong presence",
}


def _int_list(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None
    if not values or any(v <= 0 for v in values):
        raise argparse.ArgumentTypeError(f"expected positive integers, got {text!r}")
    return values


def add_arguments(p: argparse.ArgumentParser) -> None:
    lines = "\n".join(f"  {name:<11} {text}" for name, text in SCENARIOS.items())
    p.description = (
        "Benchmarks. Servers, echo peers and monitors run as separate processes; "
        "each scenario measures paramdds and its baseline in the same run.\n\n" + lines
    )
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument("scenario", choices=list(SCENARIOS), metavar="SCENARIO", help=", ".join(SCENARIOS))
    p.add_argument("--quick", action="store_true", help="a short run for smoke tests (rough figures)")
    p.add_argument(
        "--nodes",
        type=_int_list,
        metavar="N,N…",
        help="scaling, foxglove: node counts (default 10,50,100,200; 100,300,1000,10000); "
        "hosting, web: node ids in the one process (default 1000); fleet: node ids per server process (1000);"
        " record: nodes changing (10)",
    )
    p.add_argument(
        "--params",
        type=positive_int,
        metavar="P",
        help="parameters per node (scaling 50, hosting 20, persist 10 and 1000)",
    )
    p.add_argument(
        "--requests",
        type=positive_int,
        metavar="N",
        help="latency: requests per system (default 2000); web: sets (200); foxglove: changes (200); "
        "persist: journal changes (100000); fleet: gets per second (1000)",
    )
    p.add_argument(
        "--records", type=positive_int, metavar="N", help="history-store: records queried (default 1000000)"
    )
    p.add_argument("--rounds", type=positive_int, metavar="R", help="alternation rounds / repetitions")
    p.add_argument(
        "--servers",
        type=positive_int,
        metavar="K",
        help="server processes: scaling (default 2), fleet (10), foxglove's ROS 2 hosts (4)",
    )
    p.add_argument(
        "--ros-nodes",
        type=_int_list,
        metavar="N,N…",
        help="foxglove: node counts of the ROS 2 baseline (default 100,300)",
    )
    p.add_argument(
        "--rates", type=_int_list, metavar="R,R…", help="record: changes per second (default 10,100,1000)"
    )
    p.add_argument("--sites", type=_int_list, metavar="S,S…", help="zenoh: site counts (default 1,10)")
    p.add_argument(
        "--clients",
        type=positive_int,
        metavar="C",
        help="throughput: client processes (default 2); persist: concurrent clients (default 8)",
    )
    p.add_argument(
        "--viewers",
        type=positive_int,
        metavar="V",
        help="latency: monitor processes holding the node's state while it is measured (default 0)",
    )
    p.add_argument(
        "--window", type=positive_int, metavar="W", help="throughput: requests in flight per client"
    )
    p.add_argument(
        "--seconds",
        type=positive_float,
        metavar="S",
        help="throughput, persist: measured seconds per round; record: seconds per rate (default 5)",
    )
    p.add_argument(
        "--minutes", type=positive_float, metavar="M", help="soak: minutes of churn (default 60; --quick 1)"
    )


def run(args: argparse.Namespace) -> int:
    from ... import bench

    return bench.run_scenario(args.scenario, args)
