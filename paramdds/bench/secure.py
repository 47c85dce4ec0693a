"""``python -m paramdds.bench.secure``: what security costs, plain and secure in one run.

Run it in an environment with the secure Cyclone build (``paramdds keystore install``).
It makes a throwaway keystore, then for each mode (plain, secure with a full-rights
identity) on a domain of its own:

* **server start**: from spawning ``paramdds server`` to its "Serving" line (median of 3);
* **client start**: the wall time of a one-shot ``paramdds get`` (median of 5);
* **handshake**: in this process, from creating a participant to the first answered
  get (discovery, and in secure mode authentication and key exchange; median of 3);
* **round trip**: ``ParameterClient.get`` of one parameter, p50 and p99, alternating
  rounds of the two modes so load on the machine hits both alike.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

PARAMS = "parameters:\n  - {name: bench.value, type: double, value: 1.5}\n"


def _env(domain: int) -> dict[str, str]:
    return dict(os.environ, PARAMDDS_LOCALHOST="1", PARAMDDS_DOMAIN=str(domain))


def _cmd(identity: str | None) -> list[str]:
    paramdds = str(Path(sys.executable).with_name("paramdds"))
    return [paramdds] + (["--identity", identity] if identity else [])


def _start_server(identity: str | None, domain: int, params: Path) -> tuple[subprocess.Popen[str], float]:
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [*_cmd(identity), "server", "-n", "bench", "-p", str(params)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=_env(domain),
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if "Serving" in line:
            return proc, time.perf_counter() - t0
    raise RuntimeError("the server did not start")


def _stop(proc: subprocess.Popen[str]) -> None:
    proc.terminate()
    proc.communicate(timeout=10)


def _handshake(identity: Any, domain: int) -> tuple[float, Any, Any]:
    from ..dds.client import ParameterClient
    from ..dds.participant import make_participant

    t0 = time.perf_counter()
    dp = make_participant(domain, localhost=True, identity=identity)
    client = ParameterClient(dp, timeout=20)
    client.get("bench", ["bench.value"])
    return time.perf_counter() - t0, dp, client


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m paramdds.bench.secure", description=__doc__.splitlines()[0])
    p.add_argument("--domain", type=int, default=170, help="plain uses this domain id, secure the next")
    p.add_argument("--requests", type=int, default=2000, help="round trips per mode")
    args = p.parse_args(argv)
    from ..dds.participant import close_participant
    from ..secure.identity import load_identity
    from ..secure.keystore import add_identity, init_keystore

    work = Path(tempfile.mkdtemp(prefix="paramdds-secure-bench-"))
    init_keystore(work / "ks")
    admin = add_identity(work / "ks", "admin", "admin", ["*"]).path
    params = work / "params.yaml"
    params.write_text(PARAMS)
    modes = {"plain": (None, args.domain), "secure": (str(admin), args.domain + 1)}
    rows: dict[str, dict[str, float]] = {}
    servers, clients = [], {}
    for mode, (ident, domain) in modes.items():
        starts = []
        for _ in range(3):
            proc, took = _start_server(ident, domain, params)
            starts.append(took)
            _stop(proc)
        proc, _ = _start_server(ident, domain, params)
        servers.append(proc)
        cli = []
        for _ in range(5):
            t0 = time.perf_counter()
            done = subprocess.run(
                [*_cmd(ident), "get", "bench", "bench.value"],
                capture_output=True,
                env=_env(domain),
                check=False,
            )
            cli.append(time.perf_counter() - t0)
            if done.returncode != 0:
                raise RuntimeError(done.stderr)
        hands = []
        for i in range(3):
            took, dp, client = _handshake(load_identity(ident) if ident else None, domain)
            hands.append(took)
            if i < 2:
                client.close()
                close_participant(dp)
        clients[mode] = client
        rows[mode] = {
            "server_start": statistics.median(starts),
            "client_start": statistics.median(cli),
            "handshake": statistics.median(hands),
        }
    samples: dict[str, list[float]] = {m: [] for m in modes}
    rounds = 10
    for _ in range(20):  # warm-up
        for client in clients.values():
            client.get("bench", ["bench.value"])
    for r in range(rounds):
        for mode in list(modes)[r % 2 :] + list(modes)[: r % 2]:
            client = clients[mode]
            for _ in range(args.requests // rounds):
                t0 = time.perf_counter()
                client.get("bench", ["bench.value"])
                samples[mode].append(time.perf_counter() - t0)
    for mode in modes:
        rows[mode]["p50"] = _pct(samples[mode], 0.5)
        rows[mode]["p99"] = _pct(samples[mode], 0.99)
    for proc in servers:
        _stop(proc)
    head = ("mode", "get p50", "get p99", "handshake", "server start", "client start")
    print(f"{head[0]:<8} {head[1]:>9} {head[2]:>9} {head[3]:>10} {head[4]:>13} {head[5]:>13}")
    for mode, row in rows.items():
        print(
            f"{mode:<8} {row['p50'] * 1e3:>7.2f}ms {row['p99'] * 1e3:>7.2f}ms "
            f"{row['handshake'] * 1e3:>8.0f}ms "
            f"{row['server_start'] * 1e3:>11.0f}ms {row['client_start'] * 1e3:>11.0f}ms"
        )
    print(f"({args.requests} gets per mode, alternating rounds; starts and handshakes are medians)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
