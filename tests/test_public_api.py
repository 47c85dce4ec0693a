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
        "paramdds.frontend.session, paramdds.frontend.shapes, paramdds.dds.client; "
        "print(sorted(m for m in sys.modules if m.startswith(('paramdds.core.table', 'yaml'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
