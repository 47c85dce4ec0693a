"""A ROS 2 process stopped past Fast DDS's lease while the bridge itself is starved of CPU.

Real rclpy nodes in a process with a 3 s lease (announced every 1 s); the bridge a process
of its own (``paramdds ros2``), stopped and continued at random moments as a loaded machine
does (the shared-domain harness's ``--starve``), and stopped outright while the host
process resumes; a real monitor; the test's own domains.
"""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.support.ros2_shared import Starver, _Proc, _python, mirrored

from .conftest import SHORT_LEASE, RosHost
from .test_mirror import paramdds_side, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

__all__ = ["paramdds_side"]  # the fixture, used by name below

NODES = ["/starved/a", "/starved/b", "/starved/c"]
STALL = 6.0  # seconds the host process is stopped: past its 3 s lease
HELD = 0.5  # seconds of it the bridge is stopped too, before the process resumes
HELD_AFTER = 1.0  # and after


@pytest.fixture
def host(ros_env: dict[str, str], tmp_path: Path) -> Iterator[RosHost]:
    """Three plain nodes in one process with a 3 s participant lease."""
    profile = tmp_path / "short_lease.xml"
    profile.write_text(SHORT_LEASE)
    env = {**ros_env, "FASTDDS_DEFAULT_PROFILES_FILE": str(profile)}
    host = RosHost(env, *[a for n in NODES for a in ("--node", n)], "--threads", "2")
    yield host
    if host.proc.poll() is None:
        os.kill(host.proc.pid, signal.SIGCONT)
    host.close()


@pytest.fixture
def bridge_process(ros_env: dict[str, str], tmp_path: Path) -> Iterator[_Proc]:
    """``paramdds ros2`` in a process of its own (so that it can be stopped), its log kept."""
    cmd = _python("-m", "paramdds.cli", "--log-level", "info", "ros2", "--resync", "0")
    proc = _Proc(cmd, ros_env, log=tmp_path / "bridge.log")
    yield proc
    with contextlib.suppress(ProcessLookupError):
        os.kill(proc.proc.pid, signal.SIGCONT)
    proc.stop()
    print(proc.tail())


def _value(monitor: Any, node: str, name: str) -> Any:
    st = monitor.snapshot().get(node)
    entry = st.parameters.get(name) if st is not None else None
    return entry[0].value if entry is not None else None


def test_a_starved_bridge_mirrors_again_a_process_stopped_past_the_lease_within_5_s(
    host: RosHost, bridge_process: _Proc, paramdds_side: Any
) -> None:
    _, monitor = paramdds_side
    bridge = bridge_process.proc
    wait_for(lambda: mirrored(monitor, NODES) == len(NODES), 30, "every node mirrored")
    starver = Starver(bridge.pid, seed=7)
    try:
        os.kill(host.proc.pid, signal.SIGSTOP)
        try:
            time.sleep(STALL - HELD)  # past the 3 s lease, the bridge starved all along
            starver.stop()
            bridge.send_signal(signal.SIGSTOP)  # and not running when the process resumes
            time.sleep(HELD)
        finally:
            os.kill(host.proc.pid, signal.SIGCONT)
        resumed = time.monotonic()
        time.sleep(HELD_AFTER)  # the resumed process announces itself (every 1 s) to a stopped bridge
    finally:
        starver.stop()
        bridge.send_signal(signal.SIGCONT)
    wait_for(lambda: mirrored(monitor, NODES) == len(NODES), resumed + 5.0 - time.monotonic(), "back in 5 s")
    took = time.monotonic() - resumed
    assert bridge_process.log is not None
    left = bridge_process.log.read_text(errors="replace")
    assert all(f"{n} left the ROS 2 graph" in left for n in NODES), "the stall did not pass the lease"
    # a change made in ROS 2 reaches paramdds through the node's events (no periodic resync here)
    assert host.command("set /starved/b use_sim_time true") == "set ok"
    changed = time.monotonic()
    wait_for(lambda: _value(monitor, "starved/b", "use_sim_time") is True, 2.0, "the event mirrored")
    print(f"mirrored again {took:.2f} s after SIGCONT; the event in {time.monotonic() - changed:.2f} s")
