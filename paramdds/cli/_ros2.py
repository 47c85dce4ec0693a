"""``paramdds ros2``: the bridge lives in :mod:`paramdds.ros2`; this checks the extra and runs it."""

from __future__ import annotations

import argparse
import sys

from ._errors import Exit, UsageError
from ._live import wait_until_interrupted
from ._session import Session


def run_ros2(args: argparse.Namespace) -> int:
    from ..ros2 import missing
    from ..ros2.bridge import SECURE_REFUSED

    if args.identity:  # before the extra or the secure library are looked for
        raise UsageError(SECURE_REFUSED)
    reason = missing()
    if reason:
        raise UsageError(f"'paramdds ros2' cannot run: {reason}")
    if args.ros_timeout <= 0:
        raise UsageError(f"--ros-timeout must be a positive number of seconds, got {args.ros_timeout}")
    if args.ros_domain is not None and not 0 <= args.ros_domain <= 232:
        raise UsageError(f"the ROS 2 domain id must be between 0 and 232, got {args.ros_domain}")
    from ..ros2.bridge import Bridge, BridgeOptions

    options = BridgeOptions(
        mirror=() if args.no_mirror else tuple(args.mirror or ["*"]),
        exclude=tuple(args.exclude),
        expose=tuple(args.expose),
        timeout=args.ros_timeout,
        resync=max(0.0, args.resync),
        ros_domain=args.ros_domain,
    )
    session = Session(args, app_name="paramdds-ros2")
    bridge = Bridge(session.participant, session.qos, options)
    try:
        bridge.start()
        mirrored = ", ".join(options.mirror) or "nothing"
        exposed = ", ".join(options.expose) or "nothing"
        sys.stdout.write(
            f"[ROS2] bridging ROS 2 domain {bridge.ros.domain} and paramdds domain {args.domain}: "
            f"mirroring {mirrored}, exposing {exposed}\n"
        )
        sys.stdout.flush()
        wait_until_interrupted()
    finally:
        bridge.close()
        session.close()
    return Exit.OK
