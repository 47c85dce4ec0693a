"""The core must stay importable (and testable) without DDS."""

import subprocess
import sys


def test_importing_the_core_loads_no_cyclonedds() -> None:
    code = (
        "import paramdds.core, paramdds.core.table, paramdds.core.validation, paramdds.core.listing, "
        "paramdds.core.names, paramdds.core.limits, sys; "
        "loaded = sorted(m for m in sys.modules if m.startswith('cyclonedds')); "
        "assert not loaded, loaded"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
