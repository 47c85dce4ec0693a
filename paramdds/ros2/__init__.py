"""The ROS 2 bridge (``paramdds ros2``, extra ``[ros2]``): ROS 2 nodes mirrored on paramdds,
paramdds nodes exposed to ROS 2. See docs/ros2.md.

Importing this package never imports rclpy; :func:`missing` says whether it can be.
"""

from __future__ import annotations

import importlib.util

__all__ = ["ROS2_PACKAGES", "missing"]

ROS2_PACKAGES = ("rclpy", "rcl_interfaces")


def missing() -> str:
    """Why the bridge cannot run here ("" when it can): the extra's packages are not installed."""
    absent = [name for name in ROS2_PACKAGES if importlib.util.find_spec(name) is None]
    if not absent:
        return ""
    return (
        f"the ros2 extra is not installed ({', '.join(absent)} missing): pip install 'paramdds[ros2]' "
        "(wheels exist for CPython 3.10-3.12 on Linux x86_64)"
    )
