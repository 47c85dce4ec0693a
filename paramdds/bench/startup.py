"""``paramdds bench startup``: whole-process time of ``paramdds get NODE NAME``.

A server process hosts one node; paramdds's bytecode is compiled (as a first run
leaves it); then, alternating in rounds (default 7, median reported), three
commands run to completion:

* ``paramdds get bench_n0000 group0.param_000`` (the console script, as a user runs it);
* ``python -c "import cyclonedds"``: the import floor;
* ``python -c`` creating one participant with paramdds's configuration: the
  participant floor (import + participant + exit);
* ``python -c`` importing what ``paramdds get`` imports, and nothing more: the
  verb's imports (the rest of its time is DDS: entities, discovery, the call);
* ``python -c "from paramdds import ParameterMonitor"``.

The ratios are ``paramdds get`` over the participant floor and over the import floor.
"""

from __future__ import annotations

import argparse
import os
import sys

from ._common import Workers, emit, median, node_names, note, render, run_timed, worker_env
from .worker import param_name

NODE = node_names(1)[0]
GET_IMPORTS = (
    "import paramdds.cli, paramdds.cli.verbs.get, paramdds.cli._output, paramdds.cli._values, "
    "paramdds.session, paramdds.dds.client"
)


def cli_command(domain: int, localhost: bool) -> list[str]:
    script = os.path.join(os.path.dirname(sys.executable), "paramdds")
    base = [script] if os.access(script, os.X_OK) else [sys.executable, "-m", "paramdds.cli"]
    cmd = [*base, "get", NODE, param_name(0), "-d", str(domain)]
    return [*cmd, "--localhost"] if localhost else cmd


def _compile_bytecode() -> None:
    """Leave paramdds's bytecode on disk, as any first run does unless PYTHONDONTWRITEBYTECODE
    is set (some sandboxes set it): each run would otherwise compile our modules from source."""
    import compileall

    import paramdds

    compileall.compile_dir(os.path.dirname(paramdds.__file__), quiet=1)


def run(args: argparse.Namespace) -> int:
    rounds = args.rounds or (3 if args.quick else 7)
    _compile_bytecode()
    env = worker_env(args.localhost)
    participant_code = (
        "from paramdds.dds.participant import make_participant; "
        f"make_participant({args.domain}, localhost={args.localhost!r})"
    )
    commands = {
        "cli_get": cli_command(args.domain, args.localhost),
        "import": [sys.executable, "-c", "import cyclonedds"],
        "participant": [sys.executable, "-c", participant_code],
        "get_imports": [sys.executable, "-c", GET_IMPORTS],
        "monitor_import": [sys.executable, "-c", "from paramdds import ParameterMonitor"],
    }
    times: dict[str, list[float]] = {k: [] for k in commands}
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        server = workers.start("server", "--nodes", "1", "--params", "50")
        server.read("READY", 60)
        note(f"startup: {rounds} rounds of {', '.join(commands)} (after one warm-up each)")
        for cmd in commands.values():
            run_timed(cmd, env=env)
        for r in range(rounds):
            keys = list(commands)
            for key in keys[r % len(keys) :] + keys[: r % len(keys)]:
                elapsed, _out = run_timed(commands[key], env=env)
                times[key].append(elapsed)
    data = {
        "cli_get_ms": round(median(times["cli_get"]), 1),
        "import_floor_ms": round(median(times["import"]), 1),
        "participant_floor_ms": round(median(times["participant"]), 1),
        "cli_get_max_ms": round(max(times["cli_get"]), 1),
        "get_imports_ms": round(median(times["get_imports"]), 1),
        "monitor_import_ms": round(median(times["monitor_import"]), 1),
        "cli_get_over_participant": round(median(times["cli_get"]) / median(times["participant"]), 3),
        "cli_get_over_import": round(median(times["cli_get"]) / median(times["import"]), 3),
        "rounds": rounds,
        "command": " ".join(commands["cli_get"]),
    }
    table = render(
        ["command", "median ms", "max ms"],
        [
            ("paramdds get NODE NAME", data["cli_get_ms"], data["cli_get_max_ms"]),
            ('python -c "import cyclonedds"', data["import_floor_ms"], round(max(times["import"]), 1)),
            (
                "python: import + participant",
                data["participant_floor_ms"],
                round(max(times["participant"]), 1),
            ),
            (
                "python: paramdds get's imports only",
                data["get_imports_ms"],
                round(max(times["get_imports"]), 1),
            ),
            (
                'python -c "from paramdds import ParameterMonitor"',
                data["monitor_import_ms"],
                round(max(times["monitor_import"]), 1),
            ),
        ],
    )
    table += (
        f"\n\nparamdds get / participant floor: {data['cli_get_over_participant']:.2f}x; "
        f"/ import floor: {data['cli_get_over_import']:.2f}x (medians of {rounds} alternating rounds)"
    )
    emit(args, data, table)
    return 0
