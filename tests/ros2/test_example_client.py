"""``examples/ros2_client.py`` takes ``NAME:=VALUE`` without rcl's deprecation warning (rcl reads
such an argument as a remap rule in its deprecated form when given the command line)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


def test_name_value_arguments_raise_no_rcl_warning(ros_env: dict[str, str]) -> None:
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "examples" / "ros2_client.py"), "/nobody", "robot_mode:=auto"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    try:
        _, err = proc.communicate(timeout=4)  # rcl warns at init; the services never come
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    assert "deprecated" not in err, err
