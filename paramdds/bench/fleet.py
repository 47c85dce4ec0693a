"""``paramdds bench fleet``: a fleet of server processes, and what one process pays for it.

``--servers`` processes (default 10) each host ``--nodes`` node ids (default 1,000)
with ``--params`` parameters (default 20, in the proportions of real files, see
:func:`~paramdds.bench.worker.descriptor_for`). Measured in one run:

* ``synced``: a monitor process's time from its participant to holding the full
  state of every node;
* ``get``: whole-process time of ``paramdds get NODE NAME`` in the fleet, against
  the same command in an otherwise empty system (one server, one node, another
  domain), alternated in rounds, medians;
* ``foreign CPU``: two more server processes host one node each, one with the
  native filter, one filtering in its handlers (``--no-native-filter``). This
  process sends ``--rate`` gets per second (default 1,000) to fleet nodes for
  ``--seconds``; the CPU time (utime + stime) each of the two spends in that
  window is read from /proc, minus what it spent in an idle window as long;
* ``network``: what each request costs on loopback. Every request goes to every
  matched request reader (one per server process); the bytes counted on ``lo``
  during the traffic window minus an idle window, per request, are shared with
  whatever else runs in the network namespace: run the bench in one of its own
  (``unshare -n sh -c 'ip link set lo up && paramdds bench fleet …'``) for a clean
  count.
* ``network by servers``: the same count as the number of
  processes reading requests grows: first of all (before the fleet adds its own
  traffic), in a domain of its own, 1, then 10, then 50 server processes (1 node
  each; 1 and 2 with ``--quick``), and gets sent to the first one's node at
  ``--rate``. Each count gets its own idle and traffic window.
* ``partition``: the alternative that keeps foreign traffic off the process and
  the network (measured, not adopted): a process reads requests through a
  subscriber whose partitions are its node ids, and a client needs a publisher
  and writer per target node. The same traffic, written into the targets'
  partitions, is sent while a partition reader hosting one other node runs (its
  CPU) and one with the wildcard partition receives it (bytes); then the client's
  cost: writers created and the time until they all matched, for 1, 100 and
  1,000 target nodes.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

from ._common import Workers, emit, median, node_names, note, render, run_timed, worker_env
from .startup import _compile_bytecode, cli_command
from .worker import param_name

_TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """utime + stime of ``pid`` so far, from /proc/<pid>/stat."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICK


def lo_tx_bytes() -> int:
    """Bytes sent on ``lo`` of this process's network namespace (/proc/self/net/dev), 0 if unknown."""
    try:
        with open("/proc/self/net/dev", encoding="ascii") as f:
            for line in f:
                name, _, counters = line.partition(":")
                if name.strip() == "lo":
                    return int(counters.split()[8])
    except (OSError, IndexError, ValueError):
        pass
    return 0


def _send_paced(writers: list[Any], samples: list[bytes], rate: int, seconds: float) -> int:
    """Write ``samples[i]`` with ``writers[i]`` round-robin at ``rate`` per second for ``seconds``."""
    from ..dds._binding import write_serialized

    batch = max(1, rate // 100)  # 100 batches a second
    sent = 0
    start = time.monotonic()
    while True:
        elapsed = time.monotonic() - start
        if elapsed >= seconds:
            return sent
        due = int(elapsed * rate) + batch
        while sent < due:
            i = sent % len(samples)
            write_serialized(writers[i], samples[i])
            sent += 1
        time.sleep(0.01)


def run(args: argparse.Namespace) -> int:
    quick = args.quick
    servers = args.servers or (2 if quick else 10)
    per = args.nodes[0] if args.nodes else (50 if quick else 1000)
    params = args.params or (5 if quick else 20)
    seconds = args.seconds or (1.0 if quick else 5.0)
    rounds = args.rounds or (2 if quick else 5)
    rate = args.requests or (200 if quick else 1000)
    total = servers * per
    empty_domain = args.domain + 1 if args.domain < 232 else args.domain - 1


    from ..dds.participant import make_participant
    from ..dds.qos import QosProfiles
    from ..dds.wire import types as wire

    _compile_bytecode()
    env = worker_env(args.localhost)
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        # first, before the fleet's traffic is on the loopback interface too
        net_domain = args.domain + 2 if args.domain < 231 else args.domain - 2
        counts = (1, 2) if quick else (1, 10, 50)
        by_servers = _bytes_by_servers(workers, net_domain, args.localhost, counts, rate)
        note(f"fleet: {servers} server processes x {per} nodes x {params} params = {total} nodes")
        fleet = [
            workers.start("server", "--nodes", str(per), "--offset", str(k * per), "--params", str(params))
            for k in range(servers)
        ]
        empty = workers.start("server", "--nodes", "1", "--params", str(params), domain=empty_domain)
        victims = {
            kind: workers.start(
                "server", "--nodes", "1", "--offset", str(total + i), "--params", str(params), *flag
            )
            for i, (kind, flag) in enumerate((("native", ()), ("handler", ("--no-native-filter",))))
        }
        victims["partition"] = workers.start("partition", "--nodes", "1", "--offset", str(total + 2))
        everyone = workers.start("partition", "--wildcard")  # every fleet node's partition
        for w in [*fleet, empty, *victims.values(), everyone]:
            w.read("READY", 120 + total / 50)

        monitor = workers.start("monitor", "--nodes", str(total), "--timeout", str(60 + total / 100))
        synced = monitor.read("RESULT", 120 + total / 50)

        note(f"fleet: {rounds} rounds of `paramdds get` in the fleet and in an empty system")
        get_cmd = cli_command(args.domain, args.localhost)
        empty_cmd = cli_command(empty_domain, args.localhost)
        run_timed(get_cmd, env=env)
        run_timed(empty_cmd, env=env)
        times: dict[str, list[float]] = {"fleet": [], "empty": []}
        # what one `paramdds get` costs the fleet: a fleet server's CPU and the loopback
        # bytes while it runs (the empty system's runs are the idle control)
        server_cpu = dict.fromkeys(times, 0.0)
        lo_bytes = dict.fromkeys(times, 0)
        for r in range(rounds):
            order = [("fleet", get_cmd), ("empty", empty_cmd)]
            for key, cmd in order if r % 2 == 0 else order[::-1]:
                cpu0, lo0 = cpu_seconds(fleet[0].pid), lo_tx_bytes()
                times[key].append(run_timed(cmd, env=env)[0])
                server_cpu[key] += cpu_seconds(fleet[0].pid) - cpu0
                lo_bytes[key] += lo_tx_bytes() - lo0

        note(f"fleet: {rate} gets/s to fleet nodes for {seconds:g} s; CPU of the two extra servers")
        qos = QosProfiles.load()
        dp = make_participant(args.domain, localhost=args.localhost, app_name="bench-fleet")
        writer = _request_writer(dp, qos)
        targets = node_names(min(total, 10))  # a few nodes hammered
        samples = [
            wire.GetParametersRequest(
                node_id=n, client_id=0xF1EE7, request_id=i + 1, names=[param_name(0)]
            ).serialize()
            for i, n in enumerate(targets)
        ]
        readers = _wait_readers(writer, servers + 2, 20)
        pids = {kind: w.pid for kind, w in victims.items()}

        partitioned = [_request_writer(dp, qos, [n]) for n in targets]

        def window(via: list[Any] | None) -> tuple[dict[str, float], int, int]:
            cpu0 = {k: cpu_seconds(p) for k, p in pids.items()}
            lo0 = lo_tx_bytes()
            if via:
                sent = _send_paced(via, samples, rate, seconds)
            else:
                time.sleep(seconds)
                sent = 0
            time.sleep(0.2)  # let the last requests be handled
            return {k: cpu_seconds(p) - cpu0[k] for k, p in pids.items()}, lo_tx_bytes() - lo0, sent

        idle_cpu, idle_lo, _ = window(None)
        busy_cpu, busy_lo, sent = window([writer] * len(samples))
        _, part_lo, part_sent = window(partitioned)
        partition_cost = _client_partition_cost(dp, qos, node_names(total), (1, 100, 1000))
    per_second = {k: max(0.0, busy_cpu[k] - idle_cpu[k]) / seconds for k in pids}
    bytes_per_request = max(0, busy_lo - idle_lo) / sent if sent else 0.0
    part_bytes = max(0, part_lo - idle_lo) / part_sent if part_sent else 0.0
    fleet_ms, empty_ms = median(times["fleet"]), median(times["empty"])
    data = {
        "servers": servers,
        "nodes": total,
        "params_per_node": params,
        "synced_ms": round(synced["full_state_ms"], 1),
        "synced_params": synced["params"],
        "get_fleet_ms": round(fleet_ms, 1),
        "get_empty_ms": round(empty_ms, 1),
        "get_ratio": round(fleet_ms / empty_ms, 2),
        "get_server_cpu_ms": round(max(0.0, server_cpu["fleet"] - server_cpu["empty"]) * 1000 / rounds, 1),
        "get_lo_bytes_fleet": round(lo_bytes["fleet"] / rounds),
        "get_lo_bytes_empty": round(lo_bytes["empty"] / rounds),
        "foreign_rate": round(sent / seconds),
        "cpu_native_ms_per_s": round(per_second["native"] * 1000, 1),
        "cpu_handler_ms_per_s": round(per_second["handler"] * 1000, 1),
        "cpu_ratio": round(per_second["native"] / per_second["handler"], 2)
        if per_second["handler"]
        else None,
        "request_readers": readers,
        "lo_bytes_per_request": round(bytes_per_request),
        "lo_bytes_per_request_per_reader": round(bytes_per_request / readers) if readers else 0,
        "partition_cpu_ms_per_s": round(per_second["partition"] * 1000, 1),
        "partition_lo_bytes_per_request": round(part_bytes),
        "partition_client": partition_cost,
        "lo_bytes_per_request_by_servers": by_servers,
        "rounds": rounds,
    }
    rows = [
        (
            f"monitor synced: {total} nodes x {params} params",
            f"{data['synced_ms']:,} ms",
            "target <= 3,000 ms",
        ),
        (
            "`paramdds get`: fleet / empty system",
            f"{fleet_ms:,.0f} / {empty_ms:,.0f} ms",
            f"{data['get_ratio']}x (target <= 1.2x)",
        ),
        (
            "what one `paramdds get` costs: a fleet server's CPU; loopback bytes, fleet / empty",
            f"{data['get_server_cpu_ms']} ms; "
            f"{data['get_lo_bytes_fleet']:,} / {data['get_lo_bytes_empty']:,} B",
            "a new reader gets every server's retained state; the filter drops it after the network",
        ),
        (
            f"one server's CPU under {data['foreign_rate']} foreign gets/s",
            f"native {data['cpu_native_ms_per_s']} ms/s, handler {data['cpu_handler_ms_per_s']} ms/s",
            f"{data['cpu_ratio']}x (target <= 0.6x)",
        ),
        (
            f"loopback bytes per request ({readers} request readers)",
            f"{data['lo_bytes_per_request']:,} B",
            f"~{data['lo_bytes_per_request_per_reader']} B per reader",
        ),
    ]
    rows.append(
        (
            "loopback bytes per request, measured by server processes",
            " / ".join(f"{n}: {b:,} B" for n, b in by_servers.items()),
            "every request reader gets its own copy",
        )
    )
    rows.append(
        (
            "partition per node (not adopted): CPU, bytes",
            f"{data['partition_cpu_ms_per_s']} ms/s, {data['partition_lo_bytes_per_request']:,} B/request",
            "foreign requests never reach the process",
        )
    )
    for n, cost in partition_cost.items():
        rows.append(
            (
                f"partition client talking to {n} nodes",
                f"{cost['writers']} writers, matched in {cost['matched_ms']:,} ms",
                f"created in {cost['create_ms']:,} ms (paramdds: 3 writers for any number)",
            )
        )
    emit(args, data, render(["measure", "value", "compared"], rows))
    return 0


def _request_writer(dp: Any, qos: Any, partitions: list[str] | None = None) -> Any:
    """A GetParametersRequest writer with our QoS, in ``partitions`` if given (its own publisher)."""
    from cyclonedds.pub import DataWriter, Publisher
    from cyclonedds.qos import Policy, Qos

    from ..dds.topics import make_topic
    from ..dds.wire import types as wire

    owner = dp if partitions is None else Publisher(dp, qos=Qos(Policy.Partition(partitions=partitions)))
    topic = make_topic(dp, "GetParametersRequest", wire.GetParametersRequest)
    return DataWriter(owner, topic, qos.writer("GetParametersRequest"))


def _wait_readers(writer: Any, count: int, timeout: float) -> int:
    """Wait until ``writer`` has matched ``count`` readers; how many it has then."""
    deadline = time.monotonic() + timeout
    while (matched := writer.get_publication_matched_status().current_count) < count:
        if time.monotonic() > deadline:
            raise RuntimeError(f"fleet: the request writer matched {matched} of {count} servers")
        time.sleep(0.01)
    return int(matched)


def _client_partition_cost(dp: Any, qos: Any, nodes: list[str], counts: tuple[int, ...]) -> dict[str, Any]:
    """Writers a partition-per-node client needs to talk to ``n`` nodes; time to create and match them."""
    out: dict[str, Any] = {}
    for n in counts:
        if n > len(nodes):
            continue
        t0 = time.perf_counter()
        writers = [_request_writer(dp, qos, [node]) for node in nodes[:n]]
        t1 = time.perf_counter()
        deadline = time.monotonic() + 60
        pending = list(writers)
        while pending and time.monotonic() < deadline:
            pending = [w for w in pending if w.get_publication_matched_status().current_count == 0]
            time.sleep(0.002)
        t2 = time.perf_counter()
        out[str(n)] = {
            "writers": n,
            "create_ms": round((t1 - t0) * 1000, 1),
            "matched_ms": round((t2 - t0) * 1000, 1) if not pending else None,
        }
        del writers, pending
    return out


def _bytes_by_servers(
    workers: Workers, domain: int, localhost: bool, counts: tuple[int, ...], rate: int
) -> dict[str, int]:
    """Loopback bytes per get request with ``counts`` server processes reading requests:
    started one group after another in ``domain``; gets go to the first server's node."""
    from ..dds.participant import make_participant
    from ..dds.qos import QosProfiles
    from ..dds.wire import types as wire

    note(f"fleet: loopback bytes per request with {', '.join(map(str, counts))} server processes")
    qos = QosProfiles.load()
    dp = make_participant(domain, localhost=localhost, app_name="bench-fleet-net")
    writer = _request_writer(dp, qos)
    (target,) = node_names(1)
    sample = wire.GetParametersRequest(node_id=target, client_id=0xB17E5, request_id=1, names=[param_name(0)])
    data = sample.serialize()
    started: list[Any] = []
    out: dict[str, int] = {}
    for count in counts:
        group = [
            workers.start("server", "--nodes", "1", "--offset", str(i), "--params", "5", domain=domain)
            for i in range(len(started), count)
        ]
        for w in group:
            w.read("READY", 120)
        started += group
        _wait_readers(writer, count, 30)
        time.sleep(1.0)  # let discovery traffic die down before the idle window
        seconds = 2.0
        lo0 = lo_tx_bytes()
        time.sleep(seconds)
        idle = lo_tx_bytes() - lo0  # heartbeats and announcements of the servers and this process
        lo0 = lo_tx_bytes()
        sent = _send_paced([writer], [data], rate, seconds)
        time.sleep(0.2)
        busy = lo_tx_bytes() - lo0
        out[str(count)] = round(max(0, busy - idle * (seconds + 0.2) / seconds) / sent) if sent else 0
    for w in started:
        workers.stop(w)
    return out
