"""``paramdds bench schema``: what checking every set against a JSON Schema costs.

Two ``paramdds server`` processes, on one domain, serve the same parameters with the same
values (the Autoware parameter file): one node declared by the largest realworld schema
(the most parameters, ``--schema``), one by the equivalent generate_parameter_library spec
written from it (same names, types, defaults, descriptions, bounds and enums, ``--spec``).
This process sets, alternating between the two nodes in rounds (the order rotates each
round, so load from other processes hits both alike):

* ``set 1``  one parameter (a bool flipped: a real change every time);
* ``set 10`` ten parameters in one request, each checked on its own (a non-atomic set:
  the schema's whole-node check runs once per parameter).

The ratio schema / spec of p50 and p99 is the cost of the schema. Also timed, as
whole processes: ``paramdds check --autoware`` on every realworld pair, and, as the
floor, ``paramdds --help``-free start-up (``python -c 'import paramdds.cli'``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ._common import alternate, emit, note, percentile, render, run_timed, worker_env

SCHEMA_NODE = "bench_schema_node"
SPEC_NODE = "bench_spec_node"
_GPL = {"bool": "bool", "integer": "int", "double": "double", "string": "string"}


def _largest(root: Path) -> tuple[Path, Path, Any]:
    """(schema, its first parameter file, the loaded schema) with the most parameters, valid pairs only."""
    from ..errors import ParamddsError
    from ..formats.schema import load_schema
    from ..formats.schema.check import autoware_pairs, check_with_schema

    best: tuple[Path, Path, Any] | None = None
    for schema_path, params in autoware_pairs(root):
        try:
            schema = load_schema(schema_path)
        except ParamddsError:
            continue
        for path in params:
            if check_with_schema(schema, path):
                continue
            if best is None or len(schema.entries) > len(best[2].entries):
                best = (schema_path, path, schema)
            break
    if best is None:
        raise RuntimeError(f"no valid schema/parameter file pair under {root}")
    return best


def spec_text(schema: Any) -> str:
    """A generate_parameter_library spec equivalent to the schema's declarations (JSON is YAML)."""
    from ..core.values import ParameterType

    T = ParameterType
    root: dict[str, Any] = {}
    for e in schema.entries:
        d = e.descriptor
        if d.dynamic_typing:
            kind = "none"
        elif d.type.is_array:
            kind = f"{_GPL[d.type.element.label]}_array" if d.type.element is not None else "none"
        else:
            kind = _GPL[d.type.label]
        leaf: dict[str, Any] = {"type": kind, "description": d.description}
        if e.default.type is not T.NOT_SET:
            value = e.default.value
            leaf["default_value"] = list(value) if isinstance(value, tuple) else value
        validation: dict[str, Any] = {}
        r = d.floating_point_range or d.integer_range
        if r is not None and not d.type.is_array:
            validation["bounds<>"] = [r.from_value, r.to_value]
        if validation:
            leaf["validation"] = validation
        node = root
        parts = e.name.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = leaf
    return json.dumps({"bench_spec": root}, indent=1)


def _serve(args: argparse.Namespace, env: dict[str, str], *extra: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "paramdds.cli", "server", "-d", str(args.domain), *extra]
    if args.localhost:
        cmd.append("--localhost")
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, start_new_session=True
    )


def _wait_serving(proc: subprocess.Popen[str], timeout: float) -> None:
    assert proc.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            err = proc.stderr.read() if proc.stderr is not None else ""
            raise RuntimeError(f"server ended before serving: {err.strip()[-800:]}")
        if "[SERVER] Serving node" in line:
            return
    raise RuntimeError("server did not start in time")


def run(args: argparse.Namespace) -> int:
    from .ros2 import find_realworld

    realworld = find_realworld()
    if realworld is None or not (realworld / "autoware").is_dir():
        raise RuntimeError(
            "the realworld Autoware files are absent (shared/realworld/autoware beside the checkout)"
        )
    autoware = realworld / "autoware"
    quick = args.quick
    requests = args.requests or (200 if quick else 2000)
    rounds = args.rounds or (4 if quick else 10)
    warmup = 30 if quick else 200
    schema_path, params_path, schema = _largest(autoware)
    from ..core.values import ParameterType

    bools = [e.name for e in schema.entries if e.descriptor.type is ParameterType.BOOL][:10]
    if not bools:
        raise RuntimeError(f"{schema_path} declares no bool parameter to flip")
    env = worker_env(args.localhost)
    env["PARAMDDS_DOMAIN"] = str(args.domain)
    with tempfile.TemporaryDirectory(prefix="paramdds-bench-schema-") as tmp:
        spec_path = Path(tmp) / "spec.yaml"
        spec_path.write_text(spec_text(schema))
        servers = [
            _serve(args, env, "-n", SCHEMA_NODE, "--schema", str(schema_path), "-p", str(params_path)),
            _serve(args, env, "-n", SPEC_NODE, "--spec", str(spec_path), "-p", str(params_path)),
        ]
        try:
            for proc in servers:
                _wait_serving(proc, 60)
            samples = _measure(args, bools, requests, rounds, warmup)
        finally:
            for proc in servers:
                proc.terminate()
            for proc in servers:
                try:
                    proc.wait(10)
                except subprocess.TimeoutExpired:
                    proc.kill()
    check_runs = [_timed_check(autoware, env) for _ in range(3 if quick else 5)]
    import_runs = [
        run_timed([sys.executable, "-c", "import paramdds.cli"], env=env)[0] for _ in range(3 if quick else 5)
    ]
    data = _report(samples, requests, rounds)
    data.update(
        {
            "schema_file": str(schema_path.relative_to(autoware)),
            "parameters": len(schema.entries),
            "check_autoware_ms": round(min(check_runs), 1),
            "check_autoware_median_ms": round(sorted(check_runs)[len(check_runs) // 2], 1),
            "python_import_ms": round(min(import_runs), 1),
            "schemas": len(_pairs(autoware)),
            "pairs": sum(len(p) for _, p in _pairs(autoware)),
        }
    )
    rows = [
        (name, data[f"{key}_p50_us"], data[f"{key}_p99_us"], requests)
        for name, key in (
            ("set 1, schema node", "schema_set1"),
            ("set 1, spec node", "spec_set1"),
            (f"set {len(bools)}, schema node", "schema_set10"),
            (f"set {len(bools)}, spec node", "spec_set10"),
        )
    ]
    table = render(["system", "p50 µs", "p99 µs", "requests"], rows)
    table += (
        f"\n\n{data['schema_file']} ({data['parameters']} parameters) vs the equivalent spec: "
        f"schema / spec set 1 p50 {data['ratio_set1_p50']}x, p99 {data['ratio_set1_p99']}x; "
        f"set {len(bools)} p50 {data['ratio_set10_p50']}x, p99 {data['ratio_set10_p99']}x"
        f"\nparamdds check --autoware ({data['schemas']} schemas, {data['pairs']} parameter files): "
        f"{data['check_autoware_ms']} ms "
        f"(best of runs; `python -c 'import paramdds.cli'` alone: {data['python_import_ms']} ms)"
    )
    emit(args, data, table)
    return 0


def _pairs(autoware: Path) -> list[tuple[Path, list[Path]]]:
    from ..formats.schema.check import autoware_pairs

    return autoware_pairs(autoware)


def _timed_check(autoware: Path, env: dict[str, str]) -> float:
    """``paramdds check --autoware`` as a whole process, in ms (it exits 1: one pair fails)."""
    t0 = time.perf_counter_ns()
    done = subprocess.run(
        [sys.executable, "-m", "paramdds.cli", "check", "--autoware", str(autoware)],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    elapsed = (time.perf_counter_ns() - t0) / 1e6
    if done.returncode not in (0, 1):
        raise RuntimeError(f"paramdds check --autoware exited {done.returncode}: {done.stderr[-800:]}")
    return elapsed


def _measure(
    args: argparse.Namespace, bools: list[str], requests: int, rounds: int, warmup: int
) -> dict[str, list[float]]:
    from ..dds.client import ParameterClient
    from ..dds.participant import make_participant
    from ..dds.qos import QosProfiles

    dp = make_participant(args.domain, localhost=args.localhost, app_name="bench-schema")
    client = ParameterClient(dp, QosProfiles.load())
    flip = [False]
    try:
        for node in (SCHEMA_NODE, SPEC_NODE):
            client.wait_for_node(node, 15.0)

        def setter(node: str, names: list[str]) -> Callable[[], None]:
            def do() -> None:
                flip[0] = not flip[0]
                reply = client.set(node, dict.fromkeys(names, flip[0]))
                if not reply.successful:
                    raise RuntimeError(f"set refused by {node}: {reply.results}")

            return do

        systems = {
            "schema_set1": setter(SCHEMA_NODE, bools[:1]),
            "spec_set1": setter(SPEC_NODE, bools[:1]),
            "schema_set10": setter(SCHEMA_NODE, bools),
            "spec_set10": setter(SPEC_NODE, bools),
        }
        note(f"schema: warm-up, then {requests} sets per system in {rounds} alternating rounds")
        for fn in systems.values():
            for _ in range(warmup):
                fn()
        samples = alternate({name: (fn, requests) for name, fn in systems.items()}, rounds)
    finally:
        client.close()
    return samples


def _report(samples: dict[str, list[float]], requests: int, rounds: int) -> dict[str, Any]:
    data: dict[str, Any] = {}
    for name, values in samples.items():
        data[f"{name}_p50_us"] = round(percentile(values, 50), 1)
        data[f"{name}_p99_us"] = round(percentile(values, 99), 1)
    for n in ("set1", "set10"):
        for q in ("p50", "p99"):
            data[f"ratio_{n}_{q}"] = round(data[f"schema_{n}_{q}_us"] / data[f"spec_{n}_{q}_us"], 3)
    data["requests"] = requests
    data["rounds"] = rounds
    return data
