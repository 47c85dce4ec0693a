"""A set forwarded by the bridge to a ROS 2 node that does not answer in time (issue 29).

ROS 2 has no deadline: a stalled ROS 2 node may apply a forwarded set whenever it
resumes. So the bridge waits for it no longer than the paramdds caller's deadline
and then answers OUTCOME_UNKNOWN, never a per-parameter TIMEOUT (a "failure" the
node then applies). Real rclpy node (its own process, stopped with SIGSTOP), real
bridge, real client; the test's own domain.
"""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Any

import pytest

from paramdds.errors import ErrorCode, OutcomeUnknownError

from .conftest import RosHost
from .test_mirror import paramdds_side, wait_for

__all__ = ["paramdds_side"]  # the fixture, used by name below


def test_a_forwarded_set_a_stalled_ros2_node_does_not_answer_is_outcome_unknown(
    ros_env: dict[str, str], ros_hosts: Any, bridge: Any, paramdds_side: Any, tmp_path: Path
) -> None:
    params = tmp_path / "params.yaml"
    params.write_text("/arm/driver:\n  ros__parameters:\n    gain: 1.0\n")
    client, _ = paramdds_side
    host: RosHost = ros_hosts("--params-file", str(params))
    client.wait_for_node("arm/driver", timeout=30)
    assert client.get_value("arm/driver", "gain").value == 1.0
    host.proc.send_signal(signal.SIGSTOP)
    try:
        # the bridge waits min(its 2 s, the caller's deadline 2.8 s) for the node, then answers
        with pytest.raises(OutcomeUnknownError, match="ROS 2 has no deadline") as raised:
            client.set("arm/driver", {"gain": 2.0}, timeout=3.0)
        assert raised.value.code is ErrorCode.OUTCOME_UNKNOWN and "/arm/driver" in str(raised.value)
    finally:
        host.proc.send_signal(signal.SIGCONT)
    # the limit docs/reliability.md states: the resumed ROS 2 node applies it (the caller was
    # told the outcome is unknown, not that it failed), and the mirror follows its event
    wait_for(lambda: client.get_value("arm/driver", "gain").value == 2.0, 20, "the late set in the mirror")
