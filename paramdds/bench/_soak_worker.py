"""The soak bench's own worker processes: ``python -m paramdds.bench._soak_worker ROLE``.

Roles (the READY / RESULT protocol of :mod:`paramdds.bench._common`; each exits when its
stdin closes):

``client``  sets the soak parameters of its own (``soak.c{K}_a`` and ``_b``) on the nodes
            in turn, ``--rate`` writes a second, as ``--kind`` says (``plain``, ``atomic``,
            ``cas``: compare-and-set at the revision a get just read, ``mixed``: the three in
            turn), from ``go`` until ``stop``; then ``RESULT`` with its ledger: per node and
            parameter the values acknowledged as applied, refused, and of unknown outcome;
``viewer``  a monitor holding every node (a DDS :class:`ParameterMonitor`, or with ``--zenoh``
            a remote one through that router); each ``look`` is answered with
            ``RESULT {"nodes": {node: [online, {soak parameter: value}]}}``; its presence
            events go to stderr, one line each (the bench keeps them when a run fails);
``prober``  a get of one soak parameter of a random node every ``--interval`` seconds, from
            ``go`` until ``stop``; then ``RESULT`` with the latencies' percentiles and the
            failures by code.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import sys
import threading
import time
from typing import Any

from ._soak_procs import heap_probe

SOAK_PREFIX = "soak."


def _say(tag: str, **data: Any) -> None:
    sys.stdout.write(f"{tag} {json.dumps(data, separators=(',', ':'))}\n")
    sys.stdout.flush()


def _on_sigterm(_signum: int, _frame: Any) -> None:
    raise SystemExit(0)


def client_params(index: int) -> tuple[str, str]:
    """The two parameters client ``index`` writes (no other client writes them)."""
    return f"{SOAK_PREFIX}c{index}_a", f"{SOAK_PREFIX}c{index}_b"


_participants: list[Any] = []


def _participant(domain: int, localhost: bool, role: str) -> Any:
    from ..dds.participant import make_participant

    dp = make_participant(domain, localhost=localhost, app_name=f"soak-{role}")
    _participants.append(dp)
    return dp


def _stop_on_line(word: str) -> threading.Event:
    """An event set when stdin says ``word`` or closes (read on a thread of its own)."""
    stop = threading.Event()

    def read() -> None:
        try:
            for line in sys.stdin:
                if line.strip() == word:
                    break
        except (OSError, ValueError):
            pass
        stop.set()

    threading.Thread(target=read, daemon=True).start()
    return stop


def _write_once(client: Any, kind: str, node: str, values: dict[str, float]) -> tuple[dict[str, str], Any]:
    """One write; each parameter's outcome: ``applied``, ``failed:CODE`` (not applied, and
    never will be, by the client's rules) or ``unknown:CODE``; {} when a compare-and-set's
    get failed (nothing was written). With the node's reply, when it answered."""
    from ..errors import CallTimeoutError, OutcomeUnknownError, ParamddsError, UnavailableError

    try:
        if kind == "cas":
            at = client.get(node, [next(iter(values))]).at
            try:
                reply = client.set(node, values, atomic=True, if_revision=at)
            except (UnavailableError, CallTimeoutError) as exc:
                return dict.fromkeys(values, f"failed:{exc.code.value}"), None
        else:
            reply = client.set(node, values, atomic=kind == "atomic")
    except OutcomeUnknownError as exc:
        return dict.fromkeys(values, f"unknown:{exc.code.value}"), None
    except (UnavailableError, CallTimeoutError) as exc:
        # a get that failed wrote nothing; a set told UNAVAILABLE or TIMEOUT was not applied
        return ({} if kind == "cas" else dict.fromkeys(values, f"failed:{exc.code.value}")), None
    except ParamddsError as exc:  # an error this bench does not expect: it may have landed
        return dict.fromkeys(values, f"unknown:{exc.code.value}"), None
    out: dict[str, str] = {}
    for r in reply.results:
        out[r.name] = "applied" if r.successful else f"failed:{r.code.value if r.code else 'REFUSED'}"
    return out, reply


def role_client(args: argparse.Namespace) -> None:
    from ..dds.client import ParameterClient

    nodes = args.node
    a, b = client_params(args.index)
    kinds = ["plain", "atomic", "cas"] if args.kind == "mixed" else [args.kind]
    client = ParameterClient(_participant(args.domain, args.localhost, "client"), timeout=args.timeout,
                             as_=f"soak-client{args.index}")  # fmt: skip
    # node -> param -> {"applied": [...], "failed": [...], "unknown": [...]} (the values written)
    ledger: dict[str, dict[str, dict[str, list[int]]]] = {}
    counts: dict[str, int] = {}
    # each acknowledged write's "node value revision incarnation time" (which server life said
    # it applied it, and when: what a write found lost is traced with), to a file: a ledger
    # this detailed in memory would grow the client by several % an hour; line by line, so a
    # client killed leaves what it was told
    acks = open(args.acks, "a", buffering=1) if args.acks else None  # noqa: SIM115
    _say("READY", pid=os.getpid())
    if sys.stdin.readline().strip() != "go":
        return
    stop = _stop_on_line("stop")
    rng = random.Random(args.index)
    seq = 0
    period = 1.0 / args.rate
    next_at = time.monotonic()
    try:
        while not stop.is_set():
            seq += 1
            node = rng.choice(nodes)
            kind = kinds[seq % len(kinds)]
            outcome, reply = _write_once(client, kind, node, {a: float(seq), b: float(seq)})
            if acks is not None and "applied" in outcome.values():
                acks.write(f"{node} {seq} {reply.revision} {reply.incarnation:016x} {time.time():.3f}\n")
            for name, said in outcome.items():
                cls = said.split(":", 1)[0]
                ledger.setdefault(node, {}).setdefault(name, {}).setdefault(cls, []).append(seq)
                counts[f"{kind} {said}"] = counts.get(f"{kind} {said}", 0) + 1
            if not outcome:
                counts[f"{kind} get failed"] = counts.get(f"{kind} get failed", 0) + 1
            next_at += period
            stop.wait(max(0.0, next_at - time.monotonic()))
            next_at = max(next_at, time.monotonic() - period)  # no burst to catch up after a stall
        if acks is not None:
            acks.close()  # before the result: the bench reads the file once it has that
        _say("RESULT", writes=seq, counts=counts, ledger=ledger)
    finally:
        client.close()


def _look(monitor: Any, strip: str) -> dict[str, Any]:
    nodes: dict[str, Any] = {}
    for name, state in monitor.snapshot().items():
        values = {p: v.to_python() for p, (v, _d) in state.parameters.items() if p.startswith(SOAK_PREFIX)}
        nodes[name.removeprefix(strip)] = [bool(state.online), values]
    return {"nodes": nodes}


def _log_presence(event: Any) -> None:
    """A presence event on stderr (kept with the bench's logs when a run fails)."""
    kind = event.event.value
    if kind in ("online", "offline", "site_online", "site_offline", "site_status", "status"):
        where = event.site or event.node
        extra = " by_site" if event.by_site else ""
        sys.stderr.write(f"{time.time():.3f} {kind} {where}{extra} {event.status or ''}\n")
        sys.stderr.flush()


def role_viewer(args: argparse.Namespace) -> None:
    closers: list[Any] = []
    if args.zenoh:
        from ..zenoh.config import ZenohOptions, open_session
        from ..zenoh.monitor import RemoteParameterMonitor

        session = open_session(ZenohOptions(connect=[args.zenoh]))
        monitor: Any = RemoteParameterMonitor(session, sites=[args.site], on_event=_log_presence)
        closers = [monitor, session]
        strip = f"{args.site}/"
    else:
        from ..dds.monitor import ParameterMonitor

        dp = _participant(args.domain, args.localhost, "monitor")
        monitor = ParameterMonitor(dp, on_event=_log_presence)
        closers = [monitor]
        strip = ""
    _say("READY", pid=os.getpid())
    try:
        for line in sys.stdin:
            if line.strip() == "look":
                _say("RESULT", **_look(monitor, strip))
    finally:
        for c in closers:
            c.close()


def role_prober(args: argparse.Namespace) -> None:
    from ..dds.client import ParameterClient
    from ..errors import ParamddsError
    from ._common import Latencies

    client = ParameterClient(_participant(args.domain, args.localhost, "prober"), timeout=args.timeout)
    name = client_params(0)[0]
    _say("READY", pid=os.getpid())
    if sys.stdin.readline().strip() != "go":
        return
    stop = _stop_on_line("stop")
    rng = random.Random(7)
    times = Latencies()  # fixed memory: this process's RSS is measured
    failed: dict[str, int] = {}
    try:
        while not stop.is_set():
            node = rng.choice(args.node)
            t0 = time.perf_counter()
            try:
                client.get(node, [name])
                times.add((time.perf_counter() - t0) * 1e3)
            except ParamddsError as exc:
                failed[exc.code.value] = failed.get(exc.code.value, 0) + 1
            stop.wait(args.interval)
        stats = (
            {"p50": times.percentile(50), "p99": times.percentile(99), "max": times.max} if times.n else {}
        )
        _say("RESULT", gets=times.n, ms=stats, failed=failed)
    finally:
        client.close()


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m paramdds.bench._soak_worker")
    p.add_argument("role", choices=("client", "viewer", "prober"))
    p.add_argument("-d", "--domain", type=int, required=True)
    p.add_argument("--localhost", action="store_true")
    p.add_argument("--node", action="append", default=[], help="a node to write or get; repeat")
    p.add_argument("--index", type=int, default=0, help="client: its number (its parameters)")
    p.add_argument("--kind", choices=("plain", "atomic", "cas", "mixed"), default="plain")
    p.add_argument("--rate", type=float, default=4.0, help="client: writes per second")
    p.add_argument("--interval", type=float, default=0.1, help="prober: seconds between gets")
    p.add_argument("--timeout", type=float, default=3.0, help="a call's timeout")
    p.add_argument("--acks", default="", help="client: append each acknowledged write to this file")
    p.add_argument("--zenoh", default="", help="viewer: a remote monitor through this router")
    p.add_argument("--site", default="site0", help="viewer --zenoh: the site it holds")
    args = p.parse_args(argv)
    heap_probe()
    signal.signal(signal.SIGTERM, _on_sigterm)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the bench process decides when we stop
    try:
        {"client": role_client, "viewer": role_viewer, "prober": role_prober}[args.role](args)
    finally:
        if _participants:  # peers drop us at once, not after the 10 s lease
            from ..dds.participant import close_participant

            for dp in _participants:
                close_participant(dp)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
