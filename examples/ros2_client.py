"""Get and set a node's parameters from ROS 2, with rclpy's parameter client
(``AsyncParameterClient``, what ``ros2 param`` uses).

    python examples/ros2_client.py /robot1 robot.max_velocity robot.max_velocity:=2.5

``NAME`` gets a parameter, ``NAME:=VALUE`` sets it (VALUE in YAML), in order. Against a
paramdds node that ``paramdds ros2 --expose`` exposes, or any ROS 2 node. Needs the
ros2 extra; ROS_DOMAIN_ID as for any ROS 2 process. Exit status 1 if a set is refused.
"""

from __future__ import annotations

import sys
from typing import Any

import rclpy
import yaml
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient

TIMEOUT = 10.0  # seconds to wait for the node's services, then for each answer


def call(node: Any, future: Any) -> Any:
    """The answer of a service call, or a TimeoutError after TIMEOUT seconds."""
    rclpy.spin_until_future_complete(node, future, timeout_sec=TIMEOUT)
    if not future.done():
        raise TimeoutError(f"no answer in {TIMEOUT:g} s")
    return future.result()


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    target, requests = argv[0], argv[1:]
    # not sys.argv: rcl would read a NAME:=VALUE as a remap rule in its deprecated form and warn
    rclpy.init(args=[sys.argv[0]])
    node = rclpy.create_node("ros2_client_example")
    client = AsyncParameterClient(node, target)
    status = 0
    try:
        if not client.wait_for_services(TIMEOUT):
            print(f"no parameter services for {target}", file=sys.stderr)
            return 1
        for request in requests:
            name, sep, text = request.partition(":=")
            if sep:
                answer = call(node, client.set_parameters([Parameter(name, value=yaml.safe_load(text))]))
                result = answer.results[0]
                print(f"{name}: {'set' if result.successful else 'refused: ' + result.reason}")
                status = status or (0 if result.successful else 1)
            else:
                values = call(node, client.get_parameters([name])).values
                print(f"{name} = {parameter_value_to_python(values[0])!r}" if values else f"{name}: unknown")
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
