"""A real rclpy parameter client (what ``ros2 param`` uses), run as a subprocess by the tests.

``dump FQN...``: every parameter of each node with its raw value and descriptor fields,
as JSON, straight from the rcl_interfaces messages (no paramdds conversion involved).
``scenario FQN``: a fixed series of list, get, types, describe, set and atomic set
calls, and every outcome, as JSON; run against two nodes it says whether they behave
the same to a ROS 2 client.
``set FQN NAME JSON``: set one parameter as ``ros2 param set`` does (another node's
client); prints the outcome as JSON (``[successful, reason]``).
"""

from __future__ import annotations

import json
import sys
from typing import Any

TIMEOUT = 10.0

_FIELDS = (
    None,
    "bool_value",
    "integer_value",
    "double_value",
    "string_value",
    "byte_array_value",
    "bool_array_value",
    "integer_array_value",
    "double_array_value",
    "string_array_value",
)


def raw_value(msg: Any) -> dict[str, Any]:
    field = _FIELDS[msg.type]
    if field is None:
        return {"type": 0}
    v = getattr(msg, field)
    if field == "byte_array_value":
        v = [b[0] if isinstance(b, bytes) else int(b) for b in v]
    elif not isinstance(v, (bool, int, float, str)):
        v = list(v)
    return {"type": msg.type, "value": v}


def raw_descriptor(d: Any) -> dict[str, Any]:
    return {
        "type": d.type,
        "description": d.description,
        "additional_constraints": d.additional_constraints,
        "read_only": d.read_only,
        "dynamic_typing": d.dynamic_typing,
        "integer_range": [[r.from_value, r.to_value, r.step] for r in d.integer_range],
        "floating_point_range": [[r.from_value, r.to_value, r.step] for r in d.floating_point_range],
    }


class Oracle:
    def __init__(self) -> None:
        import rclpy

        self.rclpy = rclpy
        rclpy.init()
        # rclpy's default /rosout: Fast DDS then knows the graph's Log type and does not look
        # it up (a lookup Fast DDS 3.2 can crash or stall in: paramdds.ros2.rosside)
        self.node = rclpy.create_node("paramdds_test_oracle")

    def wait(self, future: Any) -> Any:
        self.rclpy.spin_until_future_complete(self.node, future, timeout_sec=TIMEOUT)
        if not future.done():
            raise TimeoutError("no answer")
        return future.result()

    def client(self, fqn: str) -> Any:
        from rclpy.parameter_client import AsyncParameterClient

        client = AsyncParameterClient(self.node, fqn)
        if not client.wait_for_services(timeout_sec=TIMEOUT):
            raise TimeoutError(f"{fqn}: parameter services not found")
        return client

    def dump(self, fqn: str) -> dict[str, Any]:
        c = self.client(fqn)
        names = sorted(self.wait(c.list_parameters([], 0)).result.names)
        values = self.wait(c.get_parameters(names)).values
        descs = self.wait(c.describe_parameters(names)).descriptors
        return {
            n: {"value": raw_value(v), "descriptor": raw_descriptor(d)}
            for n, v, d in zip(names, values, descs, strict=True)
        }

    def scenario(self, fqn: str) -> list[Any]:
        from rclpy.parameter import Parameter

        c = self.client(fqn)
        out: list[Any] = []

        def listed(prefixes: list[str], depth: int) -> None:
            r = self.wait(c.list_parameters(prefixes, depth)).result
            out.append(["list", prefixes, depth, sorted(r.names), sorted(r.prefixes)])

        def got(names: list[str]) -> None:
            out.append(["get", names, [raw_value(v) for v in self.wait(c.get_parameters(names)).values]])

        def typed(names: list[str]) -> None:
            out.append(["types", names, list(self.wait(c.get_parameter_types(names)).types)])

        def described(names: list[str]) -> None:
            r = self.wait(c.describe_parameters(names)).descriptors
            out.append(["describe", names, [raw_descriptor(d) for d in r]])

        def setting(params: list[Parameter[Any]]) -> None:
            r = self.wait(c.set_parameters(params)).results
            out.append(["set", [p.name for p in params], [[x.successful, bool(x.reason)] for x in r]])

        def atomic(params: list[Parameter[Any]]) -> None:
            r = self.wait(c.set_parameters_atomically(params)).result
            out.append(["atomic", [p.name for p in params], [r.successful, bool(r.reason)]])

        listed([], 0)
        listed(["limits"], 0)
        listed([], 1)
        got(["limits.speed", "mode", "gains", "flags", "ids", "labels", "nope"])
        typed(["limits.speed", "limits.count", "frozen", "anything", "nope"])
        described(["limits.speed", "limits.count", "frozen", "anything", "mode", "gains"])
        setting([Parameter("limits.speed", value=2.5), Parameter("limits.count", value=6)])
        setting([Parameter("limits.speed", value=9.0), Parameter("limits.count", value=3)])
        setting([Parameter("frozen", value="water"), Parameter("mode", value="wrong")])
        setting([Parameter("limits.speed", value="fast"), Parameter("anything", value="text")])
        got(["limits.speed", "limits.count", "anything", "mode"])
        atomic([Parameter("limits.speed", value=1.0), Parameter("mode", value="manual")])
        atomic([Parameter("limits.speed", value=3.0), Parameter("limits.count", value=5)])
        got(["limits.speed", "mode", "limits.count"])
        typed(["anything"])
        return out

    def set(self, fqn: str, name: str, value: Any) -> list[Any]:
        from rclpy.parameter import Parameter

        r = self.wait(self.client(fqn).set_parameters([Parameter(name, value=value)])).results[0]
        return [r.successful, r.reason]

    def events(self, fqn: str) -> list[Any]:
        """Print ``listening`` once subscribed, then the /parameter_events messages of ``fqn``
        (new, changed and deleted names with raw values) from the first one to a second after."""
        from rcl_interfaces.msg import ParameterEvent
        from rclpy.qos import qos_profile_parameter_events

        got: list[Any] = []

        def on_event(msg: Any) -> None:
            if msg.node == fqn:
                got.append(
                    {
                        "new": [[p.name, raw_value(p.value)] for p in msg.new_parameters],
                        "changed": [[p.name, raw_value(p.value)] for p in msg.changed_parameters],
                        "deleted": [p.name for p in msg.deleted_parameters],
                    }
                )

        sub = self.node.create_subscription(
            ParameterEvent, "/parameter_events", on_event, qos_profile_parameter_events
        )
        import time

        def matched() -> bool:
            """Every publisher in the graph (its own node's, and another process's) matched: the
            topic is volatile, a message sent before its writer matched is never seen."""
            known = len(self.node.get_publishers_info_by_topic("/parameter_events"))
            return known >= 2 and sub.get_publisher_count() >= known

        deadline = time.monotonic() + TIMEOUT

        def publishing() -> bool:  # the node's own writer is known, and every known writer matched
            infos = self.node.get_publishers_info_by_topic("/parameter_events")
            return any(f"{i.node_namespace.rstrip('/')}/{i.node_name}" == fqn for i in infos) and matched()

        while not publishing() and time.monotonic() < deadline:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
        for _ in range(4):  # and the writers matched it
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
        print("listening", flush=True)
        while not got and time.monotonic() < deadline + TIMEOUT:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
        after = time.monotonic() + 1.0  # the rest of what one set sent
        while time.monotonic() < after:
            self.rclpy.spin_once(self.node, timeout_sec=0.05)
        return got

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.try_shutdown()


def main() -> int:
    oracle = Oracle()
    try:
        if sys.argv[1] == "events":
            print(json.dumps(oracle.events(sys.argv[2])))
        elif sys.argv[1] == "set":
            print(json.dumps(oracle.set(sys.argv[2], sys.argv[3], json.loads(sys.argv[4]))))
        elif sys.argv[1] == "dump":
            print(json.dumps({fqn: oracle.dump(fqn) for fqn in sys.argv[2:]}))
        else:
            print(json.dumps(oracle.scenario(sys.argv[2])))
    finally:
        oracle.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
