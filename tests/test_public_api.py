"""The public API: everything in ``paramdds.__all__`` resolves, and importing it stays light."""

import subprocess
import sys

import paramdds


def test_every_exported_name_resolves() -> None:
    for name in paramdds.__all__:
        assert getattr(paramdds, name) is not None, name
    assert paramdds.ParameterClient.__module__ == "paramdds.dds.client"
    assert paramdds.ParameterTable.__module__ == "paramdds.core.table"


def test_import_paramdds_does_not_load_cyclonedds() -> None:
    code = "import paramdds, sys; print(any(m.startswith('cyclonedds') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_a_client_does_not_load_the_table() -> None:
    # `paramdds get` pays for every import: the table, its validation and YAML stay out
    code = (
        "import sys, paramdds.cli, paramdds.cli._output, paramdds.cli._values, paramdds.cli.verbs.get, "
        "paramdds.session, paramdds.dds.client; "
        "print(sorted(m for m in sys.modules if m.startswith(('paramdds.core.table', 'yaml'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# What a one-shot verb and a monitor import (issue 33): nothing of secure mode, the web
# console, YAML specs and schemas, the bridge, the journal, the benchmarks, urllib's
# network modules. asyncio (and the ssl it imports) is not in the list: Cyclone's binding
# imports it itself (``cyclonedds.core``), so no process that talks DDS can leave it out.
NOT_IMPORTED = (
    "paramdds.secure",
    "paramdds.web",
    "paramdds.ros2",
    "paramdds.formats",
    "paramdds.core.table",
    "paramdds.persist",
    "paramdds.server_process",
    "paramdds.bench",
    "yaml",
    "jsonschema",
    "referencing",
    "urllib.request",
    "http",
    "email",
    "xml",
    "importlib.resources",
    "secrets",
)


def _unwanted(loaded: str) -> list[str]:
    prefixes = tuple(f"{name}." for name in NOT_IMPORTED)
    return sorted(m for m in loaded.split() if m in NOT_IMPORTED or m.startswith(prefixes))


def test_a_one_shot_get_imports_nothing_it_does_not_use(domain_id: int) -> None:
    # the whole verb, run to its end (a node that is not there), then the import set at exit
    code = (
        "import atexit, os, sys\n"
        "atexit.register(lambda: os.write(1, ' '.join(sorted(sys.modules)).encode()))\n"
        "from paramdds.cli import main\n"
        f"main(['get', 'ghost', 'x', '--timeout', '0.3', '-d', '{domain_id}', '--localhost'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "cyclonedds.domain" in out.stdout, out.stderr  # the verb did reach DDS
    assert _unwanted(out.stdout) == []
    # the parser is built for the verb named: no other verb's module (build_parser)
    verbs = [m for m in out.stdout.split() if m.startswith("paramdds.cli.verbs.")]
    assert verbs == ["paramdds.cli.verbs.get"]


def test_a_monitor_import_imports_nothing_it_does_not_use() -> None:
    code = "import sys\nfrom paramdds import ParameterMonitor\nprint(' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "paramdds.dds.monitor" in out.stdout
    assert _unwanted(out.stdout) == []
