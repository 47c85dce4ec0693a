"""The soak's memory question, small and fast: what a long-lived state reader keeps per server life.

``python -m paramdds.bench._soak_memory -d 232 --localhost --minutes 12`` (``-o json`` for
every figure) starts ``--servers`` ``paramdds server --persist`` processes of ``--nodes``
nodes each and restarts them in turn for ``--minutes``, without a pause, cleanly (SIGTERM)
in one round and with SIGKILL in the next, while a client of this process sets two
parameters of a random node ``--rate`` times a second under two identities (new values and
blames, as the soak's clients make). Five watchers, each a process of this module
(``… _soak_memory watch KIND``), follow the state topic all along:

``monitor``  a :class:`~paramdds.dds.monitor.ParameterMonitor` with an event callback: what
             the soak's monitors, console and gateway run;
``traced``   the same with ``tracemalloc`` on: the Python heap, and the lines it grew at;
``reader``   a reader of ``ParameterEvents`` with the monitor's QoS, on a dispatcher like the
             monitor's, its samples taken and dropped undecoded: Cyclone's share;
``bare``     a participant alone: what discovering each new server participant costs;
``client``   a :class:`~paramdds.dds.client.ParameterClient` listing the nodes 5 times a
             second: what the soak's clients keep (their discovery watch).

Each watcher's RSS (and the traced one's heap and the state decoder's cache sizes) is read
after the warm-up (``--warm``, a fraction of the run) and at the end; the growth between the
two is reported per 100 server lives, with the lines of the traced heap that grew most, and
each watcher's C heap (glibc's ``mallinfo2``): bytes in use, and bytes freed but held by the
allocator. What is not in the Python heap is Cyclone's (or the allocator's). Exit 0, or 4 when a
process could not be started (one line naming it).
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from ._common import RESULT, Worker, WorkerError, emit, note, render, rss_mb, worker_env
from ._soak_procs import Proc, c_heap_mb, proc_stats

KINDS = ("monitor", "traced", "reader", "bare", "client")
PARAMS = ("soak.w0", "soak.w1")
AUTHORS = ("memory-a", "memory-b")
TOP = 12  # heap lines reported
HEADS = ["watcher", "RSS MiB warm", "end", "%", "MiB/100 lives", "heap MiB/100 lives", "C heap MiB (free)"]


# -- the watchers (each a process: ``python -m paramdds.bench._soak_memory watch KIND``) --------


def _say(tag: str, **data: Any) -> None:
    import json

    sys.stdout.write(f"{tag} {json.dumps(data, separators=(',', ':'))}\n")
    sys.stdout.flush()


def _dropping_reader(dp: Any) -> Any:
    """A reader of ``ParameterEvents`` set up as the monitor's feed sets its own, whose samples
    are taken and dropped: the dispatcher that holds it."""
    from functools import partial

    from cyclonedds.core import Policy
    from cyclonedds.qos import Qos

    from ..dds.dispatch import Dispatcher
    from ..dds.participant import poll_peers
    from ..dds.qos import QosProfiles
    from ..dds.topics import make_topic
    from ..dds.transport import transport_of
    from ..dds.wire import types as wire

    topic = make_topic(dp, "ParameterEvents", wire.ParameterEvent)
    dispatcher = Dispatcher(dp, "memory-reader", tick=partial(poll_peers, dp), period=1.0)
    qos = QosProfiles.load().reader("ParameterEvents") + Qos(Policy.History.KeepLast(4))
    reader = transport_of(dp).reader(topic, qos)
    dispatcher.add_raw(reader, lambda _data, _info: None, lambda _batch: None)
    dispatcher.start()
    return dispatcher


def _listing_client(dp: Any) -> Any:
    """A client listing the nodes every 0.2 s (each listing polls its discovery watch)."""
    from ..dds.client import ParameterClient

    client = ParameterClient(dp)

    def list_nodes() -> None:
        while True:
            try:
                client.nodes()
            except Exception:  # closed at the watcher's end
                return
            time.sleep(0.2)

    threading.Thread(target=list_nodes, name="memory-client", daemon=True).start()
    return client


def watch(kind: str, domain: int, localhost: bool) -> None:
    """A watcher: ``look`` answers its RSS, heap and the decoder's caches; ``mark`` keeps a
    heap snapshot; ``top`` answers the heap lines grown most since the mark."""
    import tracemalloc

    from ..dds.participant import close_participant, make_participant
    from ..dds.wire import state

    if kind == "traced":
        tracemalloc.start(1)
    dp = make_participant(domain, localhost=localhost, app_name=f"memory-{kind}")
    held: Any = None
    events = [0]

    def count(_event: Any) -> None:
        events[0] += 1

    if kind in ("monitor", "traced"):
        from ..dds.monitor import ParameterMonitor

        held = ParameterMonitor(dp, on_event=count)
    elif kind == "reader":
        held = _dropping_reader(dp)
    elif kind == "client":
        held = _listing_client(dp)
    _say("READY", pid=os.getpid())
    mark: Any = None
    ignore = (tracemalloc.Filter(False, tracemalloc.__file__),)
    try:
        for line in sys.stdin:
            word = line.strip()
            if word == "look":
                heap = tracemalloc.get_traced_memory()[0] / 2**20 if tracemalloc.is_tracing() else None
                caches = state.cache_sizes() if kind in ("monitor", "traced") else {}
                rss = round(rss_mb(os.getpid()), 2)
                _say(RESULT, rss_mb=rss, heap_mb=heap, c_heap=c_heap_mb(), caches=caches, events=events[0])
            elif word == "mark" and tracemalloc.is_tracing():
                mark = tracemalloc.take_snapshot().filter_traces(ignore)
                _say(RESULT)
            elif word == "top" and mark is not None:
                now = tracemalloc.take_snapshot().filter_traces(ignore)
                stats = now.compare_to(mark, "lineno")[:TOP]
                rows = [[str(s.traceback[0]), round(s.size_diff / 1024, 1), s.count_diff] for s in stats]
                _say(RESULT, top=rows)
            else:
                _say(RESULT)
    finally:
        if held is not None:
            held.close()
        close_participant(dp)


class Watcher(Worker):
    """A watcher process (the READY / RESULT protocol of :mod:`._common`), its stderr in a file."""

    def __init__(self, kind: str, *, domain: int, localhost: bool, logs: Path) -> None:
        super().__init__(
            "watch",
            [kind],
            domain=domain,
            localhost=localhost,
            module="paramdds.bench._soak_memory",
            stderr_file=logs / f"watch-{kind}.err",
            name=kind,
        )

    def ask(self, word: str) -> dict[str, Any]:
        self.send(word)
        return self.read(RESULT, 60.0)


# -- the churn ----------------------------------------------------------------------------------


class Churn:
    """The servers, restarted in turn, and the writing client (see the module doc)."""

    def __init__(self, args: argparse.Namespace, tmp: Path) -> None:
        self.tmp = tmp
        self.env = worker_env(args.localhost)
        self.gflags = ["-d", str(args.domain), *(["--localhost"] if args.localhost else [])]
        self.nodes = [[f"memory_n{k}_{j}" for j in range(args.nodes)] for k in range(args.servers)]
        self.servers: list[Proc | None] = [None] * args.servers
        self.lives = 0
        self.unclean_stops = 0  # clean stops SIGTERM did not end (the group killed after the grace)
        self.writes = {"applied": 0, "failed": 0}
        self._stop = threading.Event()
        self._writer: threading.Thread | None = None
        for k, nodes in enumerate(self.nodes):
            params = "".join(f"    {p}: 0.0\n" for p in PARAMS) + "    gain: 1.5\n"
            text = "".join(f"{n}:\n  ros__parameters:\n{params}" for n in nodes)
            (tmp / f"server{k}.yaml").write_text(text)

    def start(self, k: int) -> None:
        argv = [*self.gflags, "server", "-p", str(self.tmp / f"server{k}.yaml")]
        argv += ["--persist", str(self.tmp / f"server{k}.persist")]
        argv += [a for node in self.nodes[k] for a in ("-n", node)]
        proc = Proc(f"server{k}", "paramdds.cli", argv, self.env, self.tmp)
        self.servers[k] = proc
        proc.wait_for("[SERVER] Serving", len(self.nodes[k]))
        self.lives += 1

    def stop(self, k: int, *, kill: bool) -> None:
        proc = self.servers[k]
        if proc is not None:
            proc.stop(kill=kill)
            self.unclean_stops += not kill and proc.proc.returncode != 0
        self.servers[k] = None

    def start_writing(self, domain: int, localhost: bool, rate: float) -> None:
        self._writer = threading.Thread(target=self._write, args=(domain, localhost, rate), daemon=True)
        self._writer.start()

    def _write(self, domain: int, localhost: bool, rate: float) -> None:
        from ..dds.client import ParameterClient
        from ..dds.participant import close_participant, make_participant
        from ..errors import ParamddsError

        dp = make_participant(domain, localhost=localhost, app_name="memory-writer")
        clients = [ParameterClient(dp, timeout=1.0, as_=who) for who in AUTHORS]
        nodes = [n for ns in self.nodes for n in ns]
        rng = random.Random(5)
        seq = 0
        try:
            while not self._stop.is_set():
                seq += 1
                try:
                    clients[seq % len(clients)].set(rng.choice(nodes), dict.fromkeys(PARAMS, float(seq)))
                    self.writes["applied"] += 1
                except ParamddsError:  # the node's server is down: UNAVAILABLE, TIMEOUT
                    self.writes["failed"] += 1
                self._stop.wait(1.0 / rate)
        finally:
            for c in clients:
                c.close()
            close_participant(dp)

    def close(self) -> None:
        self._stop.set()
        if self._writer is not None:
            self._writer.join(timeout=10.0)
        for k in range(len(self.servers)):
            self.stop(k, kill=False)


def _look(watchers: dict[str, Watcher], churn: Churn, t0: float) -> dict[str, Any]:
    seen: dict[str, Any] = {}
    for kind, w in watchers.items():
        said = w.ask("look")
        said.pop("_at_ns", None)
        stats = proc_stats(w.pid)
        seen[kind] = {**said, "rss_mb": stats["rss_mb"] if stats else None}
    return {"at_s": round(time.monotonic() - t0, 1), "lives": churn.lives, "watchers": seen}


def run(args: argparse.Namespace) -> int:
    seconds = args.minutes * 60.0
    kinds = [k for k in args.watch.split(",") if k]
    tmp = Path(tempfile.mkdtemp(prefix="paramdds-memory-"))
    churn = Churn(args, tmp)
    watchers: dict[str, Watcher] = {}
    try:
        for k in range(args.servers):
            churn.start(k)
        for kind in kinds:
            watchers[kind] = Watcher(kind, domain=args.domain, localhost=args.localhost, logs=tmp)
        for w in watchers.values():
            w.read("READY", 90.0)
        churn.start_writing(args.domain, args.localhost, args.rate)
        note(f"{args.servers} servers x {args.nodes} nodes restarted in turn for {args.minutes:g} min")
        t0 = time.monotonic()
        warm_at, end = t0 + args.warm * seconds, t0 + seconds
        warm: dict[str, Any] | None = None
        series: list[dict[str, Any]] = []
        next_look = t0
        turn = 0
        while time.monotonic() < end:
            k = turn % args.servers
            churn.stop(k, kill=(turn // args.servers) % 2 == 1)  # a clean round, then a killing one
            churn.start(k)
            turn += 1
            now = time.monotonic()
            if warm is None and now >= warm_at:
                warm = _look(watchers, churn, t0)
                if "traced" in watchers:
                    watchers["traced"].ask("mark")
                note(f"warm-up look at {warm['at_s']} s, {warm['lives']} lives")
            if now >= next_look:
                series.append(_look(watchers, churn, t0))
                next_look = now + args.every
        final = _look(watchers, churn, t0)
        top = watchers["traced"].ask("top")["top"] if "traced" in watchers and warm is not None else []
    except WorkerError as exc:
        note(f"bench soak memory: {exc} (logs in {tmp})")
        return 4
    finally:
        churn.close()
        for w in watchers.values():
            w.stop()
    data = _data(args, warm or final, final, series, top, churn)
    shutil.rmtree(tmp, ignore_errors=True)
    emit(args, data, _table(data))
    return 0


def _data(
    args: argparse.Namespace,
    warm: dict[str, Any],
    end: dict[str, Any],
    series: list[dict[str, Any]],
    top: list[Any],
    churn: Churn,
) -> dict[str, Any]:
    lives = end["lives"] - warm["lives"]
    growth: dict[str, Any] = {}
    for kind, w in warm["watchers"].items():
        e = end["watchers"][kind]
        grown = e["rss_mb"] - w["rss_mb"]
        heap = None if w["heap_mb"] is None else e["heap_mb"] - w["heap_mb"]
        growth[kind] = {
            "rss_mb": [w["rss_mb"], e["rss_mb"]],
            "growth_pct": round(100.0 * grown / w["rss_mb"], 1),
            "rss_mib_per_100_lives": round(100.0 * grown / lives, 3) if lives else None,
            "heap_mib_per_100_lives": round(100.0 * heap / lives, 3) if lives and heap is not None else None,
            "caches": [w["caches"], e["caches"]],
            "c_heap_mb": [w["c_heap"], e["c_heap"]],
        }
    return {
        "minutes": args.minutes,
        "servers": args.servers,
        "nodes_per_server": args.nodes,
        "lives": end["lives"],
        "lives_after_warm_up": lives,
        "warm_at_s": warm["at_s"],
        "end_at_s": end["at_s"],
        "writes": churn.writes,
        "unclean_stops": churn.unclean_stops,
        "watchers": growth,
        "heap_grown_kib": top,
        "series": series,
        "load_average": list(os.getloadavg()),
    }


def _table(data: dict[str, Any]) -> str:
    rows = []
    for kind, g in data["watchers"].items():
        per = g["rss_mib_per_100_lives"]
        heap = g["heap_mib_per_100_lives"]
        c0, c1 = g["c_heap_mb"]
        c = "" if c0 is None or c1 is None else f"{c0['used']} -> {c1['used']} ({c0['free']} -> {c1['free']})"
        rows.append([kind, g["rss_mb"][0], g["rss_mb"][1], f"{g['growth_pct']:+.1f}",
                     "" if per is None else f"{per:.3f}", "" if heap is None else f"{heap:.3f}",
                     c])  # fmt: skip
    lines = [
        f"soak memory: {data['servers']} servers x {data['nodes_per_server']} nodes, {data['lives']} server "
        f"lives in {data['end_at_s']} s ({data['lives_after_warm_up']} after the warm-up look at "
        f"{data['warm_at_s']} s); writes {data['writes']}; "
        f"stops that needed SIGKILL: {data['unclean_stops']}",
        render(HEADS, rows),
    ]
    if data["heap_grown_kib"]:
        lines.append("traced heap grown since the warm-up (KiB, objects):")
        lines += [f"  {where}: {kib:+.1f} KiB, {count:+d}" for where, kib, count in data["heap_grown_kib"]]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["watch"]:
        p = argparse.ArgumentParser(prog="python -m paramdds.bench._soak_memory watch")
        p.add_argument("kind", choices=KINDS)
        p.add_argument("-d", "--domain", type=int, required=True)
        p.add_argument("--localhost", action="store_true")
        w = p.parse_args(argv[1:])
        watch(w.kind, w.domain, w.localhost)
        return 0
    p = argparse.ArgumentParser(prog="python -m paramdds.bench._soak_memory", description=__doc__)
    p.add_argument("-d", "--domain", type=int, required=True)
    p.add_argument("--localhost", action="store_true")
    p.add_argument("--minutes", type=float, default=12.0)
    p.add_argument("--servers", type=int, default=3)
    p.add_argument("--nodes", type=int, default=5, help="nodes per server")
    p.add_argument("--rate", type=float, default=8.0, help="writes a second (two parameters each)")
    p.add_argument("--warm", type=float, default=0.25, help="the warm-up, a fraction of the run")
    p.add_argument("--every", type=float, default=60.0, help="seconds between the looks kept in the JSON")
    p.add_argument("--watch", default=",".join(KINDS), help=f"watchers, comma-separated ({', '.join(KINDS)})")
    p.add_argument("-o", "--output", choices=("table", "json"), default="table")
    return run(p.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
