"""``paramdds bench persist``: what ``--persist`` costs per set, and a restart from a long journal.

Sets per second: a ``paramdds server`` process hosting one node of ``P`` parameters
(``--params``, default 10 and 1,000), and client processes (one, then ``--clients``,
default 8: ``setter`` workers, each with its own participant and client, without a
presence reader, as the CLI's) that set one
parameter after another (each waits for its reply) for ``--seconds`` (default 3), all
from the same instant of the machine's monotonic clock. The same server without
``--persist`` is the baseline; the two alternate in rounds (``--rounds``, default 3)
and the median round is reported, with the ratio. With several clients the server's
group commit lets concurrent sets share one ``fdatasync``. The clients are processes,
not threads of the bench: threads of one process share its interpreter lock, so eight
of them measured the bench's own Python as much as the server.

Restart: a persistence file for a node of 1,000 parameters whose journal holds
``--requests`` changes (default 100,000; written in one append, as a server would have
written them one by one), then the whole ``paramdds server`` process is timed from
its start until it serves the node. The baseline is the same start from the same
snapshot with an empty journal.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ._common import RESULT, Worker, Workers, emit, median, note, render, worker_env

NODE = "bench_persist"
RESTART_PARAMS = 1000


def _params_file(directory: Path, count: int) -> Path:
    path = directory / f"params{count}.yaml"
    lines = [f"{NODE}:", "  ros__parameters:"]
    lines += [f"    {param_name(i)}: {i}" for i in range(count)]
    path.write_text("\n".join(lines) + "\n")
    return path


# ``python -m paramdds.cli`` that ends with the bench (SIGTERM when its parent dies, on Linux),
# so a crashed bench leaves no server answering the next run on the same domain
_CLI_DYING_WITH_PARENT = (
    "import ctypes, runpy, signal, sys\n"
    "try:\n"
    "    ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG\n"
    "except (OSError, AttributeError):\n"
    "    pass\n"
    "sys.argv[0] = 'paramdds'\n"
    "runpy.run_module('paramdds.cli', run_name='__main__', alter_sys=True)\n"
)


class _Server:
    """A ``paramdds server`` subprocess, timed from its start until it serves the node."""

    def __init__(self, args: argparse.Namespace, params: Path, persist: Path | None) -> None:
        cmd = [sys.executable, "-c", _CLI_DYING_WITH_PARENT, "server", "-n", NODE, "-p", str(params)]
        if persist is not None:
            cmd += ["--persist", str(persist)]
        env = worker_env(args.localhost)
        env["PARAMDDS_DOMAIN"] = str(args.domain)
        t0 = time.perf_counter()
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            if line.startswith("[SERVER] Serving node"):
                break
        else:
            raise RuntimeError(
                f"the server did not start: {self.proc.stderr.read() if self.proc.stderr else ''}"
            )
        self.start_ms = (time.perf_counter() - t0) * 1e3

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.communicate()


def param_name(i: int) -> str:
    return f"p{i:05d}"


def set_until(client: Any, count: int, lane: int, lanes: int, end: float) -> int:
    """Lane ``lane`` of ``lanes``: set the node's parameters in turn until ``end``
    (``time.monotonic()``), each set waiting for its reply; how many were set."""
    from ..core.values import Parameter, ParameterValue

    n = 0
    while time.monotonic() < end:
        name = param_name((lane + n * lanes) % count)
        reply = client.set(NODE, [Parameter(name, ParameterValue.from_python(n))])
        if not reply.successful:
            raise RuntimeError(f"a set failed: {reply.results}")
        n += 1
    return n


def _sets_per_s(clients: list[Worker], count: int, seconds: float) -> float:
    """Sets per second of the ``clients`` (setter workers) setting at once."""
    for client in clients:
        client.send("wait")
    for client in clients:
        client.read(RESULT, 30.0)  # each has found the node
    start = time.monotonic() + 0.2  # every worker is asleep until then (the clock is the machine's)
    for i, client in enumerate(clients):
        job = {"count": count, "lane": i, "lanes": len(clients), "start": start, "end": start + seconds}
        client.send(f"go {json.dumps(job)}")
    done = [client.read(RESULT, seconds + 60.0) for client in clients]
    errors = [d["error"] for d in done if "error" in d]
    if errors:
        raise RuntimeError(errors[0])
    sets = sum(int(d["sets"]) for d in done)
    return sets / (max(float(d["finished"]) for d in done) - start)


def _round(
    args: argparse.Namespace, clients: list[Worker], directory: Path, count: int, persist: bool
) -> float:
    state = directory / f"state{count}.yaml"
    for leftover in (state, Path(f"{state}.journal")):
        leftover.unlink(missing_ok=True)
    server = _Server(args, _params_file(directory, count), state if persist else None)
    try:
        return _sets_per_s(clients, count, args.seconds or (0.5 if args.quick else 3.0))
    finally:
        server.stop()


def _journal_of(directory: Path, changes: int) -> Path:
    """A persistence file for NODE (1,000 parameters) whose journal holds ``changes`` changes."""
    from ..core.descriptors import ParameterDescriptor
    from ..core.results import ChangeKind, ChangeSet, ParameterChange
    from ..core.table import ParameterTable
    from ..core.values import ParameterType, ParameterValue
    from ..server_process import persist_store

    state = directory / "restart.yaml"
    table = ParameterTable(NODE)
    for i in range(RESTART_PARAMS):
        table.declare(param_name(i), i)
    store = persist_store(str(state))
    store.compact_every = changes + 1
    store.attach({NODE: table})
    sets = [
        ChangeSet(
            NODE,
            2 + n,
            (
                ParameterChange(
                    ChangeKind.CHANGED,
                    param_name(n % RESTART_PARAMS),
                    ParameterValue.from_python(n),
                    ParameterDescriptor(param_name(n % RESTART_PARAMS), ParameterType.INTEGER),
                ),
            ),
        )
        for n in range(changes)
    ]
    store.record(table, sets)
    store.close()
    return state


def run(args: argparse.Namespace) -> int:
    counts = [args.params] if args.params else [10, 1000]
    rounds = args.rounds or (1 if args.quick else 3)
    changes = args.requests or (10_000 if args.quick else 100_000)
    data: dict[str, Any] = {"rounds": rounds}
    rows: list[tuple[object, ...]] = []
    with tempfile.TemporaryDirectory(prefix="paramdds-bench-persist-") as tmp:
        directory = Path(tmp)
        concurrent = args.clients or 8
        for count in counts:
            for lanes in dict.fromkeys([1, concurrent]):
                persisted: list[float] = []
                plain: list[float] = []
                with Workers(localhost=args.localhost, domain=args.domain) as workers:
                    # only the clients measured exist: every client process receives the node's
                    # state, so idle ones would cost the server as much as busy ones
                    clients = [workers.start("setter", "--node", NODE) for _ in range(lanes)]
                    for client in clients:
                        client.read("READY", 60.0)
                    for r in range(rounds):
                        for persist in (True, False) if r % 2 == 0 else (False, True):
                            note(
                                f"persist: {count} params, {lanes} client(s), "
                                f"--persist {'on' if persist else 'off'}, round {r + 1}"
                            )
                            rate = _round(args, clients, directory, count, persist)
                            (persisted if persist else plain).append(rate)
                tag = f"{count}" if lanes == 1 else f"{count}_c{lanes}"
                data[f"sets_per_s_{tag}"] = round(median(persisted), 0)
                data[f"sets_per_s_{tag}_no_persist"] = round(median(plain), 0)
                data[f"ratio_{tag}"] = round(median(persisted) / median(plain), 3)
                data[f"ratios_{tag}"] = [round(p / q, 3) for p, q in zip(persisted, plain, strict=True)]
                rows.append(
                    (
                        f"sets/s, {count} params, {lanes} client{'s' if lanes > 1 else ''}",
                        data[f"sets_per_s_{tag}"],
                        data[f"sets_per_s_{tag}_no_persist"],
                        data[f"ratio_{tag}"],
                    )
                )
        note(f"persist: writing a journal of {changes:,} changes")
        state = _journal_of(directory, changes)
        journal_mb = os.path.getsize(f"{state}.journal") / 1e6
        params = _params_file(directory, RESTART_PARAMS)
        restart: list[float] = []
        empty: list[float] = []
        for _ in range(rounds):
            copy = directory / "restart-copy.yaml"
            for src, dst in ((state, copy), (Path(f"{state}.journal"), Path(f"{copy}.journal"))):
                dst.write_bytes(src.read_bytes())  # each start compacts: start from the same files
            server = _Server(args, params, copy)
            restart.append(server.start_ms)
            server.stop()  # its compaction left an empty journal: the baseline's start
            server = _Server(args, params, copy)
            empty.append(server.start_ms)
            server.stop()
    data.update(
        restart_ms=round(median(restart), 0),
        restart_empty_journal_ms=round(median(empty), 0),
        journal_changes=changes,
        journal_mb=round(journal_mb, 1),
    )
    rows.append(
        (
            f"restart, {changes:,}-change journal (ms)",
            data["restart_ms"],
            data["restart_empty_journal_ms"],
            round(data["restart_ms"] / data["restart_empty_journal_ms"], 2),
        )
    )
    table = render(["measure", "--persist", "baseline", "ratio"], rows)
    table += (
        "\n\nbaseline: the same server without --persist, the same clients (sets; medians of the rounds, "
        "ratio of the medians), the same start with an empty journal "
        f"(restart); journal {data['journal_mb']} MB"
    )
    emit(args, data, table)
    return 0
