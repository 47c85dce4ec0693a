"""A ROS 2 node (rclpy) with a few parameters, for `paramdds ros2` to mirror.

    python examples/ros2_node.py            # then, in another shell:
    paramdds ros2                            # and in a third:
    paramdds get arm/driver gain

It declares /arm/driver's parameters with descriptors (ranges, read-only, a
description) and refuses, in its own set callback, a mode it does not know. Needs
the ros2 extra (pip install 'paramdds[ros2]'); ROS_DOMAIN_ID as for any ROS 2
process. Ctrl-C stops it cleanly (it leaves the ROS 2 graph at once).
"""

from __future__ import annotations

from typing import Any

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

MODES = ("position", "velocity", "torque")


def make_node() -> Node:
    node = Node("driver", namespace="/arm")
    node.declare_parameter(
        "gain",
        1.5,
        ParameterDescriptor(
            description="proportional gain",
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=10.0, step=0.0)],
        ),
    )
    node.declare_parameter(
        "rate_hz",
        100,
        ParameterDescriptor(
            description="control loop rate",
            integer_range=[IntegerRange(from_value=10, to_value=1000, step=10)],
        ),
    )
    node.declare_parameter(
        "mode", "position", ParameterDescriptor(additional_constraints="one of: " + ", ".join(MODES))
    )
    node.declare_parameter(
        "joints",
        ["shoulder", "elbow", "wrist"],
        ParameterDescriptor(read_only=True, description="joint names"),
    )

    def check(params: list[Any]) -> SetParametersResult:
        for p in params:
            if p.name == "mode" and p.value not in MODES:
                return SetParametersResult(successful=False, reason=f"unknown mode {p.value!r}")
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(check)
    return node


def main() -> None:
    rclpy.init()
    node = make_node()
    count = len(node.list_parameters([], 0).names)
    print(f"[ROS2 NODE] {node.get_fully_qualified_name()} ready with {count} parameters", flush=True)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
