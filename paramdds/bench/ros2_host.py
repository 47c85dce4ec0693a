"""A process of real rclpy nodes for tests and benchmarks: ``python -m paramdds.bench.ros2_host``.

Every node named in the parameter files (``--params-file``, ROS 2 format, read by rcl's
own YAML parser) is created with ``automatically_declare_parameters_from_overrides``, so
it holds exactly the file's parameters; ``--node NAME`` adds nodes with no file entry.
``--rich NAME`` gives a node parameters with full descriptors (ranges, read-only,
description, dynamic typing, a constraint its callback enforces); ``--hang NAME`` makes
a node's set callback sleep 60 s when a parameter named ``hang`` is set; ``--mute NAME``
makes a node without parameter services (until ``serve``); ``--unknown K`` gives every node K
publishers of message types a bridge has no endpoint of (:data:`UNKNOWN_TYPES`, in turn).

Prints ``ready /ns/a /ns/b ...`` once its nodes exist, then reads commands on stdin:
``set FQN NAME YAML`` sets a parameter from inside the node (as its own code would), ``hush
FQN NAME YAML`` the same without its ``/parameter_events`` message (what a peer that lost it sees),
``get FQN NAME`` prints its value as JSON, ``serve FQN`` starts a muted node's parameter
services, ``blink FQN SECONDS`` makes a node that lives that long (as a tool's node, such as
``ros2 param``'s, does), ``strip FQN`` destroys a node's parameter services and its
``/parameter_events`` publisher and keeps the node (its name stays in the graph with none of
them: what a peer sees of a node whose process left while the graph update of its going was
lost), ``quit`` (or end of input) shuts down cleanly: every node leaves the graph, in the
order made, before ROS 2 shuts down.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
from typing import Any

import yaml

HANG_SECONDS = 60.0
# message types of the ros2 extra that a bridge's ROS 2 side has no endpoint of (module, class)
UNKNOWN_TYPES = (
    ("lifecycle_msgs.msg", "TransitionEvent"),
    ("action_msgs.msg", "GoalStatusArray"),
    ("unique_identifier_msgs.msg", "UUID"),
)
_stopping = threading.Event()  # set on quit: a hanging callback returns at once


def names_in(files: list[str]) -> list[tuple[str, str]]:
    """(namespace, name) of every node a parameter file names (``/**/x`` -> ``/x``)."""
    out: list[tuple[str, str]] = []

    def walk(doc: object, path: list[str]) -> None:
        if not isinstance(doc, dict):
            return
        for key, sub in doc.items():
            if key == "ros__parameters":
                parts = [p for p in path if p not in ("**", "*")]
                if parts and (("/" + "/".join(parts[:-1])), parts[-1]) not in out:
                    out.append(("/" + "/".join(parts[:-1]), parts[-1]))
            else:
                walk(sub, [*path, *(p for p in str(key).split("/") if p)])

    for path in files:
        with open(path) as f:
            walk(yaml.safe_load(f) or {}, [])
    return out


def _rich(node: Any) -> None:
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
    from rclpy.parameter import Parameter

    node.declare_parameter(
        "limits.speed",
        1.5,
        ParameterDescriptor(
            description="top speed (m/s)",
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=5.0, step=0.0)],
        ),
    )
    node.declare_parameter(
        "limits.count",
        4,
        ParameterDescriptor(
            description="how many", integer_range=[IntegerRange(from_value=0, to_value=10, step=2)]
        ),
    )
    node.declare_parameter("frozen", "ice", ParameterDescriptor(read_only=True, description="never changes"))
    node.declare_parameter("anything", 3, ParameterDescriptor(dynamic_typing=True))
    node.declare_parameter("mode", "auto", ParameterDescriptor(additional_constraints="one of: auto, manual"))
    node.declare_parameter("gains", [1.0, 2.0, 3.0])
    node.declare_parameter("flags", [True, False])
    node.declare_parameter("ids", [1, 2, 3])
    node.declare_parameter("labels", ["a", "b"])

    def check(params: list[Parameter[Any]]) -> SetParametersResult:
        for p in params:
            if p.name == "mode" and p.value not in ("auto", "manual"):
                return SetParametersResult(
                    successful=False, reason=f"mode must be auto or manual, not {p.value!r}"
                )
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(check)


def _hang(node: Any) -> None:
    from rcl_interfaces.msg import SetParametersResult

    def slow(params: list[Any]) -> SetParametersResult:
        if any(p.name == "hang" for p in params):
            _stopping.wait(HANG_SECONDS)
        return SetParametersResult(successful=True)

    node.declare_parameter("hang", 0)
    node.add_on_set_parameters_callback(slow)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m paramdds.bench.ros2_host")
    ap.add_argument("--params-file", action="append", default=[])
    ap.add_argument("--node", action="append", default=[], help="a node with no file entry (/ns/name)")
    ap.add_argument("--rich", action="append", default=[], help="a node with full descriptors (/ns/name)")
    ap.add_argument("--hang", action="append", default=[], help="a node whose callback hangs on 'hang'")
    ap.add_argument("--mute", action="append", default=[], help="a node without parameter services")
    ap.add_argument("--threads", type=int, default=4, help="executor threads (1: single-threaded)")
    ap.add_argument("--unknown", type=int, default=0, help="publishers per node of unknown types")
    args = ap.parse_args(argv)

    import rclpy
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
    from rclpy.parameter import Parameter

    ros_args = ["--ros-args"]
    for f in args.params_file:
        ros_args += ["--params-file", f]
    rclpy.init(args=ros_args)
    wanted = names_in(args.params_file)
    for fqn in [*args.node, *args.rich, *args.hang, *args.mute]:
        ns, _, name = fqn.rpartition("/")
        if (ns or "/", name) not in wanted:
            wanted.append((ns or "/", name))
    nodes: dict[str, Any] = {}
    muted = {tuple(f.rpartition("/")[::2]) for f in args.mute}
    for ns, name in wanted:
        node = rclpy.create_node(
            name,
            namespace=ns,
            automatically_declare_parameters_from_overrides=True,
            start_parameter_services=((ns if ns != "/" else ""), name) not in muted,
        )
        nodes[node.get_fully_qualified_name()] = node
    if args.unknown:
        import importlib

        kinds = [getattr(importlib.import_module(m), c) for m, c in UNKNOWN_TYPES]
        for node in nodes.values():
            for i in range(args.unknown):
                node.create_publisher(kinds[i % len(kinds)], f"~/unknown_{i}", 1)
    for fqn in args.rich:
        _rich(nodes[fqn])
    for fqn in args.hang:
        _hang(nodes[fqn])
    executor = MultiThreadedExecutor(args.threads) if args.threads > 1 else SingleThreadedExecutor()
    for node in nodes.values():
        executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    print("ready", *nodes, flush=True)
    try:
        for line in sys.stdin:
            words = line.split(maxsplit=3)
            if not words:
                continue
            if words[0] == "quit":
                break
            if words[0] in ("set", "hush") and len(words) == 4:
                node = nodes[words[1]]
                events = node._parameter_event_publisher
                if words[0] == "hush":  # no /parameter_events message for it: as one lost
                    node._parameter_event_publisher = None
                try:
                    result = node.set_parameters([Parameter(words[2], value=yaml.safe_load(words[3]))])[0]
                finally:
                    node._parameter_event_publisher = events
                print(words[0], "ok" if result.successful else f"refused {result.reason}", flush=True)
            if words[0] == "serve" and len(words) == 2:
                from rclpy.parameter_service import ParameterService

                node = nodes[words[1]]
                node._parameter_service = ParameterService(node)
                print("served", flush=True)
            if words[0] == "strip" and len(words) == 2:
                node = nodes[words[1]]
                for service in list(node.services):
                    node.destroy_service(service)
                node.destroy_publisher(node._parameter_event_publisher)
                node._parameter_event_publisher = None
                print("stripped", flush=True)
            if words[0] == "blink" and len(words) == 3:
                ns, _, name = words[1].rpartition("/")
                node = rclpy.create_node(name, namespace=ns or "/")
                executor.add_node(node)
                _stopping.wait(float(words[2]))
                executor.remove_node(node)
                node.destroy_node()
                print("blinked", flush=True)
            if words[0] == "get" and len(words) == 3:
                value = nodes[words[1]].get_parameter(words[2]).value
                if not isinstance(value, (bool, int, float, str)):
                    value = list(value)  # a tuple, list or array.array
                print("value", json.dumps(value), flush=True)
    except KeyboardInterrupt:
        pass
    _stopping.set()
    executor.shutdown(timeout_sec=2.0)  # spin returns
    spinner.join(timeout=5.0)
    # every node leaves the graph while ROS 2 runs, then ROS 2 shuts down: rclpy's try_shutdown
    # destroys the nodes it tracks while dropping each from the list it walks (every other
    # one), and the rest, destroyed after it, left the graph late or only with the lease
    for node in nodes.values():
        node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
