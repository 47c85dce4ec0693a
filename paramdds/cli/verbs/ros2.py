"""``paramdds ros2``: the bridge lives in :mod:`paramdds.ros2`; this verb checks the extra and runs it."""

from __future__ import annotations

import argparse

HELP = "mirror ROS 2 nodes on paramdds, expose paramdds nodes to ROS 2 (ros2 extra)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--mirror",
        action="append",
        default=[],
        metavar="GLOB",
        help="ROS 2 nodes (/ns/name globs) to mirror on paramdds; repeat (default: every node)",
    )
    p.add_argument(
        "--exclude", action="append", default=[], metavar="GLOB", help="ROS 2 nodes never mirrored; repeat"
    )
    p.add_argument(
        "--no-mirror", action="store_true", help="mirror no ROS 2 node (only expose paramdds nodes)"
    )
    p.add_argument(
        "--expose",
        action="append",
        default=[],
        metavar="GLOB",
        help="paramdds nodes (globs) to serve to ROS 2 tools; repeat (default: none)",
    )
    p.add_argument(
        "--ros-domain",
        type=int,
        metavar="N",
        help="the ROS 2 domain (default: ROS_DOMAIN_ID, else 0); may differ from -d",
    )
    p.add_argument(
        "--ros-timeout",
        type=float,
        default=5.0,
        metavar="SECONDS",
        help="how long a call to a ROS 2 node waits when no paramdds caller set a deadline: the "
        "bridge's reads and retained assignments; a set waits until its caller's --timeout "
        "(default %(default)s)",
    )
    p.add_argument(
        "--resync",
        type=float,
        default=60.0,
        metavar="SECONDS",
        help="check each mirrored node's values this often (one node every SECONDS / nodes), "
        "0 never (default %(default)s)",
    )


def run(args: argparse.Namespace) -> int:
    import sys

    from ...exits import Exit, UsageError
    from ...ros2 import missing
    from ...ros2.bridge import SECURE_REFUSED
    from ...session import Session
    from .._live import wait_until_interrupted

    if args.identity:  # before the extra or the secure library are looked for
        raise UsageError(SECURE_REFUSED)
    reason = missing()
    if reason:
        raise UsageError(f"'paramdds ros2' cannot run: {reason}")
    if args.ros_timeout <= 0:
        raise UsageError(f"--ros-timeout must be a positive number of seconds, got {args.ros_timeout}")
    if args.ros_domain is not None and not 0 <= args.ros_domain <= 232:
        raise UsageError(f"the ROS 2 domain id must be between 0 and 232, got {args.ros_domain}")
    from ...ros2.bridge import Bridge, BridgeOptions

    _report_crashes()

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


def _report_crashes() -> None:
    """A crash in native code (rclpy, Fast DDS, the cyclonedds binding) of a long-running bridge
    leaves every thread's Python stack on the process's stderr (its log), not only an exit
    status; SIGUSR1 dumps them too, without stopping it (a bridge that hangs)."""
    import faulthandler
    import signal
    import sys

    stream = sys.__stderr__  # the process's own: sys.stderr may be replaced by an object without a descriptor
    if stream is None:  # no stderr at all: nothing to write to
        return
    try:
        if not faulthandler.is_enabled():
            faulthandler.enable(stream, all_threads=True)
        if hasattr(faulthandler, "register"):  # not on Windows
            faulthandler.register(signal.SIGUSR1, stream, all_threads=True, chain=False)
    except (AttributeError, OSError, ValueError):  # no stderr with a file descriptor: nothing to write to
        pass
