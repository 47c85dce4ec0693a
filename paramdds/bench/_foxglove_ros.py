"""foxglove_bridge's way to a Parameters panel, in rclpy: ``python -m paramdds.bench._foxglove_ros N R S``.

One long-lived process (the bridge is one) that waits until the N nodes ``/bench_nNNNN``
are in the graph with their parameter services ready, then, R times (rounds), answers a
panel's get-all as ros-foxglove-bridge's ``ParameterInterface::getParams`` does: the graph's
node names, each node's services (only nodes offering ListParameters and GetParameters),
a parameter client per node (kept between rounds), a node whose service is not ready
fails, then ``list_parameters`` and ``get_parameters`` per node, all nodes at once, each
call bounded by a 5 s timeout; a node that failed is ignored from then on (the bridge's
ignore list). Then S changes (sets) of ``/bench_n0000``'s ``group0.param_000`` through its
parameter client, each timed until its ``/parameter_events`` message reaches this
process (where the bridge would push it to the panel). Prints one JSON line.

The node spins in an executor on a thread of its own, as the bridge's node spins in its
own; the main thread issues the calls and polls their futures every millisecond. This is
rclpy, not the bridge's C++: the same calls, with Python's cost per callback.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from typing import Any

TIMEOUT = 5.0  # the bridge's timeout per parameter call
NODE0, PARAM0 = "/bench_n0000", "group0.param_000"
_LIST = "rcl_interfaces/srv/ListParameters"
_GET = "rcl_interfaces/srv/GetParameters"


def _ms(t0: float) -> float:
    return round((time.perf_counter() - t0) * 1e3, 3)


def probe(n: int, rounds: int, sets: int) -> dict[str, Any]:
    from paramdds.ros2.rosside import fqn_of, quiet_imports

    quiet_imports()
    import rclpy
    from rcl_interfaces.msg import ParameterEvent
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    from rclpy.qos import qos_profile_parameter_events

    rclpy.init()
    node = rclpy.create_node("foxglove_bridge_probe")
    me = node.get_fully_qualified_name()
    wanted = {f"/bench_n{i:04d}" for i in range(n)}
    deadline = time.monotonic() + 120 + n / 5
    while True:  # the graph is known without spinning (rmw's discovery thread keeps it)
        present = {fqn_of(name, ns) for name, ns in node.get_node_names_and_namespaces()} & wanted
        if present == wanted:
            break
        if time.monotonic() > deadline:
            raise SystemExit(f"ros probe: {len(present)} of {n} nodes in the graph")
        time.sleep(0.05)
    # every entity before the executor spins (rclpy deadlocks creating one while it does)
    clients = {fqn: AsyncParameterClient(node, fqn) for fqn in sorted(wanted)}
    seen: list[float] = []
    expected: dict[str, Any] = {}

    def on_event(event: Any) -> None:
        if event.node == NODE0 and "at" in expected:
            for p in event.changed_parameters:
                if p.name == PARAM0 and p.value.double_value == expected["value"]:
                    seen.append(_ms(expected.pop("at")))

    node.create_subscription(ParameterEvent, "/parameter_events", on_event, qos_profile_parameter_events)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    while not all(c.services_are_ready() for c in clients.values()):  # the bridge has been running
        if time.monotonic() > deadline:
            raise SystemExit("ros probe: parameter services not ready")
        time.sleep(0.05)
    time.sleep(1.0)  # the event subscription matches the nodes' writers
    ignored: set[str] = {me}
    round_ms: list[float] = []
    graph_ms: list[float] = []
    answered: list[int] = []
    params: list[int] = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        targets = []
        for name, ns in node.get_node_names_and_namespaces():
            fqn = fqn_of(name, ns)
            if fqn in ignored:
                continue
            types = {t for _srv, ts in node.get_service_names_and_types_by_node(name, ns) for t in ts}
            if _LIST in types and _GET in types:
                targets.append(fqn)
        graph_ms.append(_ms(t0))
        pending: dict[Any, tuple[str, str, float]] = {}
        failed: set[str] = set()
        for fqn in targets:
            client = clients.get(fqn)
            if client is None or not client.services_are_ready():  # a new client is never ready yet
                failed.add(fqn)
                continue
            pending[client.list_parameters([], 0)] = (fqn, "list", time.perf_counter())
        got: dict[str, int] = {}
        while pending:
            time.sleep(0.001)
            now = time.perf_counter()
            for future, (fqn, what, started) in list(pending.items()):
                if future.done():
                    del pending[future]
                    if what == "list":
                        names = list(future.result().result.names)
                        pending[clients[fqn].get_parameters(names)] = (fqn, "get", now)
                    else:
                        got[fqn] = len(future.result().values)
                elif now - started > TIMEOUT:
                    del pending[future]
                    failed.add(fqn)
        round_ms.append(_ms(t0))
        ignored |= failed
        answered.append(len(got))
        params.append(sum(got.values()))

    latency: list[float] = []
    lost = 0
    warm = max(1, sets // 10)
    for i in range(sets + warm):
        expected["value"] = 100.0 + i * 0.5
        expected["at"] = time.perf_counter()
        before = len(seen)
        future = clients[NODE0].set_parameters([Parameter(PARAM0, value=expected["value"])])
        end = time.monotonic() + TIMEOUT
        while (len(seen) == before or not future.done()) and time.monotonic() < end:
            time.sleep(0.0005)
        if len(seen) == before:
            lost += 1
            expected.pop("at", None)
        elif i >= warm:
            latency.append(seen[-1])
    rclpy.try_shutdown()  # wakes the executor, which returns from spin (ros2_host's order)
    spinner.join(timeout=5.0)
    executor.shutdown(timeout_sec=2.0)
    node.destroy_node()
    return {
        "round_ms": round_ms,
        "graph_ms": graph_ms,
        "answered": answered,
        "params": params,
        "ignored": len(ignored) - 1,
        "latency_ms": latency,
        "lost": lost,
    }


def main() -> int:
    n, rounds, sets = (int(a) for a in sys.argv[1:4])
    print(json.dumps(probe(n, rounds, sets)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
