"""Real ROS 2 (rclpy from PyPI, Fast DDS) for the bridge's tests.

Every ROS 2 process runs on a random ``ROS_DOMAIN_ID`` (1-99: paramdds tests use
100-230), discovers on loopback only over UDP (no Fast DDS shared memory), and logs
to a temporary directory. Without the ros2 extra the tests skip with the reason;
under ``CI=true`` they fail.
"""

from __future__ import annotations

import contextlib
import os
import queue
import random
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from paramdds.dds.participant import close_participant, make_participant
from paramdds.ros2 import missing
from tests.conftest import make_dds_env
from tests.support.realworld import find_realworld

REALWORLD = find_realworld()
ORACLE = Path(__file__).with_name("ros_oracle.py")


# a Fast DDS profile whose participants announce a 3 s lease (the default is 20 s), every 1 s:
# given to a ROS 2 process (FASTDDS_DEFAULT_PROFILES_FILE), its going is seen within 3 s
SHORT_LEASE = """<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com">
  <participant profile_name="short_lease" is_default_profile="true">
    <rtps>
      <builtin>
        <discovery_config>
          <leaseDuration><sec>3</sec></leaseDuration>
          <leaseAnnouncement><sec>1</sec></leaseAnnouncement>
        </discovery_config>
      </builtin>
    </rtps>
  </participant>
</profiles>
"""


def require_ros2() -> None:
    reason = missing()
    if reason:
        if os.environ.get("CI", "").strip().lower() in {"1", "true", "yes"}:
            pytest.fail(f"CI: {reason}")
        pytest.skip(reason)


def ros_vars(tmp_path: Path) -> dict[str, str]:
    """The variables ROS 2 processes need here: a random domain, loopback discovery over
    UDP only (no Fast DDS shared memory), logs under ``tmp_path``."""
    return {
        "ROS_DOMAIN_ID": str(random.randint(1, 99)),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
        "ROS_LOG_DIR": str(tmp_path / "roslog"),
        "RCUTILS_LOGGING_BUFFERED_STREAM": "0",
    }


@pytest.fixture
def ros_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, domain_id: int) -> dict[str, str]:
    """ROS 2's environment, set in this process too (for an in-process bridge); returns the
    environment for subprocesses (ROS 2 and paramdds on ``domain_id``)."""
    require_ros2()
    ros = ros_vars(tmp_path)
    for k, v in ros.items():
        monkeypatch.setenv(k, v)
    return make_dds_env(domain_id, **ros)


class RosHost:
    """``python -m paramdds.bench.ros2_host`` in a subprocess: real rclpy nodes until :meth:`close`."""

    def __init__(self, env: dict[str, str], *args: str, timeout: float = 30.0) -> None:
        self.args = args
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "paramdds.bench.ros2_host", *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
        )
        self._lines: queue.Queue[str] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        first = self.line(timeout)
        assert first.startswith("ready"), first
        self.nodes = first.split()[1:]

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._lines.put(line.strip())
        self._lines.put("<eof>")

    def line(self, timeout: float = 10.0) -> str:
        try:
            return self._lines.get(timeout=timeout)
        except queue.Empty:
            raise AssertionError("the ROS 2 host said nothing in time") from None

    def command(self, text: str) -> str:
        assert self.proc.stdin is not None
        self.proc.stdin.write(text + "\n")
        self.proc.stdin.flush()
        return self.line()

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                assert self.proc.stdin is not None
                self.proc.stdin.write("quit\n")
                self.proc.stdin.close()
                self.proc.wait(timeout=15)
            except (subprocess.TimeoutExpired, BrokenPipeError, OSError):
                self.proc.kill()
                self.proc.wait()
        self._release()

    def kill(self) -> None:
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        self._release()

    def _release(self) -> None:
        self._reader.join(timeout=5.0)  # the process is gone: its output ends
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None and not stream.closed:
                with contextlib.suppress(OSError):
                    stream.close()


@pytest.fixture
def bridge(ros_env: dict[str, str], domain_id: int) -> Iterator[Any]:
    """A bridge on this test's domain mirroring every ROS 2 node (2 s forwarding timeout, no
    periodic resync), closed after the test."""
    from paramdds.ros2.bridge import Bridge, BridgeOptions

    dp = make_participant(domain_id, localhost=True)
    b = Bridge(dp, None, BridgeOptions(timeout=2.0, resync=0)).start()
    yield b
    b.close()
    close_participant(dp)


@pytest.fixture
def ros_hosts(ros_env: dict[str, str]) -> Iterator[Any]:
    """``start(*args)`` -> a RosHost; all are shut down cleanly at the end."""
    hosts: list[RosHost] = []

    def start(*args: str) -> RosHost:
        host = RosHost(ros_env, *args)
        hosts.append(host)
        return host

    yield start
    for host in hosts:
        host.close()


def paramdds_cli(env: dict[str, str], *args: str, timeout: float = 10.0) -> subprocess.CompletedProcess[str]:
    """``paramdds ARGS --timeout TIMEOUT`` as a process in ``env``, its output captured."""
    return subprocess.run(
        [sys.executable, "-m", "paramdds.cli", *args, "--timeout", str(timeout)],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def oracle(env: dict[str, str], *args: str, timeout: float = 60.0) -> Any:
    """Run the rclpy client of ros_oracle.py; its JSON output."""
    import json

    out = subprocess.run(
        [sys.executable, str(ORACLE), *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout)
