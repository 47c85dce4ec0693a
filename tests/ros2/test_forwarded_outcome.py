"""A set forwarded by the bridge to a ROS 2 node that does not answer in time (issues 29, 30).

ROS 2 has no deadline: a stalled ROS 2 node may apply a forwarded set whenever it
resumes. So the bridge waits for it until the paramdds caller's deadline (the caller's
``--timeout``, longer than the bridge's own ``--ros-timeout`` here) and then answers
OUTCOME_UNKNOWN (exit 5), never a per-parameter TIMEOUT (a "failure" the node then
applies) nor "offline". Meanwhile the mirror stays online, marked ``stale``, and reads are
answered from the bridge's copy. Real rclpy node (its own process, stopped with SIGSTOP),
real bridge, real client; the test's own domain.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.values import Parameter, ParameterValue
from paramdds.dds.monitor import EventKind
from paramdds.errors import ErrorCode, OutcomeUnknownError, ParamddsError
from paramdds.ros2.mirror import MirrorTable
from paramdds.ros2.rosside import Unanswered

from .conftest import RosHost
from .test_mirror import paramdds_side, wait_for

pytestmark = pytest.mark.slow

__all__ = ["paramdds_side"]  # the fixture, used by name below


def test_a_stalled_ros2_node_stays_readable_as_stale_and_its_forwarded_set_is_outcome_unknown(
    ros_env: dict[str, str],
    ros_hosts: Any,
    bridge: Any,
    paramdds_side: Any,
    tmp_path: Path,
    request: pytest.FixtureRequest,
) -> None:
    params = tmp_path / "params.yaml"
    params.write_text("/arm/driver:\n  ros__parameters:\n    gain: 1.0\n")
    client, monitor = paramdds_side
    host: RosHost = ros_hosts("--params-file", str(params))
    client.wait_for_node("arm/driver", timeout=30)
    assert client.get_value("arm/driver", "gain").value == 1.0
    assert bridge.options.timeout == 2.0  # the bridge's own wait: the caller's 4 s must win
    # the status changes are events, live: the monitor's (the web console's), and watch's lines
    events: list[tuple[EventKind, str | None]] = []
    monitor.add_callback(
        lambda e: (
            events.append((e.event, e.status))
            if e.node == "arm/driver" and e.event in (EventKind.STATUS, EventKind.OFFLINE)
            else None
        )
    )
    watch = _Watch(ros_env, "arm/driver")
    request.addfinalizer(watch.stop)
    host.proc.send_signal(signal.SIGSTOP)
    try:
        started = time.monotonic()
        cli = subprocess.Popen(
            [sys.executable, "-m", "paramdds.cli", "set", "arm/driver", "gain=2.0", "--timeout", "4"],
            env=ros_env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        # past the 1 s lease the mirror shows stale (online, values kept), and reads go on
        wait_for(lambda: monitor.snapshot()["arm/driver"].status == "stale", 10, "the mirror shown stale")
        state = monitor.snapshot()["arm/driver"]
        assert state.online and state.parameters["gain"][0].value == 1.0
        table = subprocess.run(
            [sys.executable, "-m", "paramdds.cli", "nodes", "--timeout", "5"],
            env=ros_env,
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
        assert any(line.split()[:2] == ["/arm/driver", "stale"] for line in table.stdout.splitlines()), table
        assert client.get_value("arm/driver", "gain", timeout=2.0).value == 1.0
        out, err = cli.communicate(timeout=30)
        took = time.monotonic() - started
        assert cli.returncode == 5, (cli.returncode, out, err)  # OUTCOME_UNKNOWN
        assert "outcome unknown" in err and "ROS 2 has no deadline" in err and "offline" not in err, err
        assert took > 3.0, took  # the caller's 4 s honoured, not the bridge's 2 s
        # the API says the same, with the code
        with pytest.raises(OutcomeUnknownError, match="ROS 2 has no deadline") as raised:
            client.set("arm/driver", {"gain": 3.0}, timeout=2.5)
        assert raised.value.code is ErrorCode.OUTCOME_UNKNOWN and "/arm/driver" in str(raised.value)
    finally:
        host.proc.send_signal(signal.SIGCONT)
    # the limit docs/reliability.md states: the resumed ROS 2 node applies them (the caller was
    # told the outcome is unknown, not that it failed), the mirror follows its events and is
    # no longer stale
    wait_for(lambda: client.get_value("arm/driver", "gain").value == 3.0, 20, "the late sets in the mirror")
    wait_for(lambda: monitor.snapshot()["arm/driver"].status is None, 10, "the mirror no longer stale")
    # stale from the first set's lease (or the bridge's probe) until the node resumed, through
    # both sets (a set that gave up does not show a stopped process ok), never offline
    assert events == [(EventKind.STATUS, "stale"), (EventKind.STATUS, None)]
    wait_for(lambda: len(watch.statuses()) >= 2, 10, "watch's status lines")
    time.sleep(0.5)
    assert watch.statuses() == ["stale", None], watch.lines


class _Watch:
    """``paramdds watch NODE -o json`` in a process of its own, its lines read as they come."""

    def __init__(self, env: dict[str, str], node: str) -> None:
        self.lines: list[dict[str, Any]] = []
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "paramdds.cli", "watch", node, "-o", "json"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        wait_for(lambda: any(line["event"] == "synced" for line in self.lines), 20, "watch synced")

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(json.loads(line))

    def statuses(self) -> list[str | None]:
        return [line["status"] for line in self.lines if line["event"] == "status"]

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10)
        self._reader.join(5)
        assert self.proc.stdout is not None
        self.proc.stdout.close()


class _FailsAfterSending:
    """The link of a node whose service call failed after the request went out (an rclpy
    future that ends in an exception)."""

    fqn = "/arm/driver"

    def set(self, params: Any, atomic: bool, deadline: int = 0) -> Any:
        raise Unanswered(
            "/arm/driver/set_parameters failed after it was sent: boom", code=ErrorCode.UNAVAILABLE
        )


class _NotThere(_FailsAfterSending):
    def set(self, params: Any, atomic: bool, deadline: int = 0) -> Any:
        raise ParamddsError(
            "the ROS 2 service /arm/driver/set_parameters is not available", code=ErrorCode.UNAVAILABLE
        )


@pytest.mark.parametrize("atomic", [False, True])
def test_a_forwarded_call_that_fails_after_it_was_sent_is_outcome_unknown(atomic: bool) -> None:
    """The write may have landed: OUTCOME_UNKNOWN, not a per-parameter UNAVAILABLE. A call that
    was never sent (the service is not there) is refused per parameter, as before."""
    table = MirrorTable("arm/driver", _FailsAfterSending())  # type: ignore[arg-type]
    table.resync({})
    params = [Parameter("gain", ParameterValue.from_python(2.0))]
    setter = table.set_atomically if atomic else table.set
    with pytest.raises(OutcomeUnknownError, match="failed after it was sent"):
        setter(params)
    table.link = _NotThere()  # type: ignore[assignment]
    outcome = (table.set_atomically if atomic else table.set)(params)
    assert [(r.successful, r.code) for r in outcome.results] == [(False, ErrorCode.UNAVAILABLE)]
