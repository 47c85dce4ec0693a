"""Exit 4: a failure that is not the node's answer (here: DDS cannot start in this process)."""

from __future__ import annotations

import subprocess

from ._support import PARAMDDS, cli_env, next_domain

NO_INTERFACE = (
    '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface name="nosuchif0"/>'
    "</Interfaces></General></Domain></CycloneDDS>"
)


def _get(env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    args = [PARAMDDS, "get", "ghost", "x", "--timeout", "0.5"]
    return subprocess.run(args, env=env, capture_output=True, text=True, timeout=30)


def test_a_local_dds_failure_exits_4_not_1() -> None:
    env = cli_env(next_domain())
    control = _get(env)  # positive control: DDS works, the node is absent: exit 3
    assert control.returncode == 3, control.stderr
    env.update(CYCLONEDDS_URI=NO_INTERFACE, PARAMDDS_LOCALHOST="0")
    out = _get(env)
    assert out.returncode == 4, out.stderr
    assert "paramdds: error: DDS failed in this process" in out.stderr
