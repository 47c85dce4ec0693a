"""`record`, `history --from` and `diff --from` on bad input: one line on stderr and exit 2, no DDS."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from ..reliability.conftest import PARAMDDS


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([PARAMDDS, *args], capture_output=True, text=True, timeout=30)


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["record"], "required: -o"),
        (["record", "-o", "/nonexistent-dir/x.mcap"], "cannot write /nonexistent-dir/x.mcap"),
        (["record", "-o", "x.mcap", "--split", "10"], "--split: not a size"),
        (["record", "-o", "x.mcap", "--split", "1KB"], "under 64 KiB"),
        (["history", "robot1", "--from", "missing.mcap"], "missing.mcap: cannot read"),
        (["history", "robot1", "--from", "params.yaml"], "params.yaml: not an MCAP file"),
        (["diff", "robot1@2", "robot1", "--from", "params.yaml"], "params.yaml: not an MCAP file"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    args: list[str], says: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.yaml").write_text("robot1:\n  ros__parameters: {}\n")
    done = run(*args)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("paramdds: error: "), done.stderr
    assert says in done.stderr
    assert not (tmp_path / "x.mcap").exists()
