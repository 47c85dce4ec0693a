"""The liveness probes of one real ROS 2 process (``paramdds.ros2.liveness``), driven as the
bridge's loop drives them: a process stopped with SIGSTOP is asked more often, and its first
answer after SIGCONT wakes the caller (the bridge looks at once, not at its next 0.5 s look).

A real rclpy host process and a real :class:`~paramdds.ros2.rosside.RosSide`; no bridge.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from paramdds.ros2.liveness import PROBE_EVERY, PROBE_STALLED, Liveness

from .conftest import RosHost
from .test_mirror import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(90)]

NODE = "/probed/node"
PROCESS = b"the-process"  # the key the bridge gives a process (its GUID prefix); any bytes here


@pytest.fixture
def probed(ros_env: dict[str, str], ros_hosts: Any) -> Iterator[tuple[RosHost, Any]]:
    from paramdds.ros2.rosside import RosSide

    host: RosHost = ros_hosts("--node", NODE)
    side = RosSide(None, "liveness_test")
    yield host, side
    if host.proc.poll() is None:
        os.kill(host.proc.pid, signal.SIGCONT)
    side.close()


def _drive(look: Callable[[], dict[bytes, float]], seconds: float) -> dict[bytes, float]:
    """``look`` every 50 ms for ``seconds`` (as the bridge's loop, faster); the last verdict."""
    end = time.monotonic() + seconds
    stalled: dict[bytes, float] = {}
    while time.monotonic() < end:
        stalled = look()
        time.sleep(0.05)
    return stalled


def test_a_stopped_process_is_asked_more_often_and_its_answer_wakes_the_bridge(probed: Any) -> None:
    host, side = probed
    answered = threading.Event()
    liveness = Liveness(on_answer=answered.set)

    def look() -> dict[bytes, float]:
        return liveness.update({PROCESS: {NODE: side}}, time.monotonic())

    try:
        wait_for(
            lambda: look() == {} and liveness.sent >= 2,
            15,
            "the probes answered",
        )
        sent = liveness.sent
        assert _drive(look, 2.0) == {}
        running = liveness.sent - sent  # one a second while it answers
        assert 1 <= running <= 3, running
        assert not answered.is_set()  # a running process's answers wake nobody
        os.kill(host.proc.pid, signal.SIGSTOP)
        wait_for(
            lambda: PROCESS in look(),
            5,
            "the stopped process shown stalled",
        )
        sent = liveness.sent
        assert PROCESS in _drive(look, 2.0)
        stopped = liveness.sent - sent  # every 0.25 s while it does not answer
        assert stopped >= 5, (stopped, PROBE_STALLED, PROBE_EVERY)
        os.kill(host.proc.pid, signal.SIGCONT)
        resumed = time.monotonic()
        wait_for(
            lambda: look() is not None and answered.wait(0.05),
            5,
            "an answer that wakes the bridge",
        )
        woke = time.monotonic() - resumed
        assert look() == {}
        print(f"probes: {running} in 2 s running, {stopped} in 2 s stopped; woken {woke:.2f} s after SIGCONT")
    finally:
        liveness.close()
