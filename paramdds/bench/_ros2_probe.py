"""One fresh process of ``paramdds bench ros2``: ``python -m paramdds.bench._ros2_probe MODE ...``.

Modes (each prints one JSON line and exits):

* ``ros-dump N PREFIX TIMEOUT QUIET``: an rclpy process that learns the whole system as a
  good tool would: waits for the N nodes in the graph (or, QUIET > 0, until no new one
  appeared for QUIET seconds), then lists, gets and describes every node concurrently
  (every request in flight at once), each node bounded by TIMEOUT; then counts the
  ROS 2 graph (topics, services, endpoints, participants; not timed).
* ``ros-get NODE NAME``: one get through ``AsyncParameterClient`` (whole-process time
  is measured by the caller).
* ``ros-warm NODE NAME COUNT``: COUNT gets then COUNT sets of NAME (a double), one at a
  time, each timed.
* ``dds-dump N PREFIX TIMEOUT``: a paramdds monitor until every node ``PREFIX####`` is
  complete or offline (a node of a killed host goes offline within the lease).
* ``dds-warm NODE NAME COUNT``: the same as ros-warm with a paramdds client.
* ``dds-graph``: topics, endpoints and participants of the paramdds system.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

T0 = time.perf_counter()


def _ms(t: float) -> float:
    return round((time.perf_counter() - t) * 1e3, 3)


def _names(n: int, prefix: str) -> list[str]:
    return [f"{prefix}{i:04d}" for i in range(n)]


def _ros() -> Any:
    from paramdds.ros2.rosside import quiet_imports

    quiet_imports()
    import rclpy

    rclpy.init()
    # with its own /rosout (rclpy's default, as `ros2 param` has), Fast DDS knows the Log type
    # of the graph's N /rosout writers and does not look it up: Fast DDS 3.2's type lookup
    # can crash on such a burst (see paramdds.ros2.rosside; seen here: a probe at N = 300)
    return rclpy, rclpy.create_node("paramdds_bench_probe")


def ros_dump(n: int, prefix: str, timeout: float, quiet: float) -> dict[str, Any]:
    from rclpy.parameter_client import AsyncParameterClient

    rclpy, node = _ros()
    wanted = set(_names(n, prefix))
    t_start = time.perf_counter()
    deadline = t_start + 60.0
    seen: set[str] = set()
    changed = t_start
    while time.perf_counter() < deadline:
        present = {f"{ns.rstrip('/')}/{name}" for name, ns in node.get_node_names_and_namespaces()} & wanted
        if present != seen:
            seen, changed = present, time.perf_counter()
        # all there, or (``quiet`` > 0: a tool that cannot know a host died) no new node for
        # ``quiet`` seconds
        if seen == wanted or (quiet > 0 and seen and time.perf_counter() - changed > quiet):
            break
        rclpy.spin_once(node, timeout_sec=0.01)
    discovered = _ms(t_start)
    clients = {fqn: AsyncParameterClient(node, fqn) for fqn in sorted(seen)}
    state: dict[str, dict[str, Any]] = {fqn: {} for fqn in clients}
    pending: dict[Any, tuple[str, str]] = {}
    started: dict[str, float] = {}
    failed: set[str] = set()
    for fqn, c in clients.items():
        pending[c.list_parameters([], 0)] = (fqn, "list")
        started[fqn] = time.perf_counter()
    while pending:
        rclpy.spin_once(node, timeout_sec=0.005)
        now = time.perf_counter()
        for future, (fqn, what) in list(pending.items()):
            if future.done():
                del pending[future]
                if what == "list":
                    names = list(future.result().result.names)
                    state[fqn]["names"] = names
                    c = clients[fqn]
                    pending[c.get_parameters(names)] = (fqn, "get")
                    pending[c.describe_parameters(names)] = (fqn, "describe")
                else:
                    state[fqn][what] = future.result()
            elif now - started[fqn] > timeout:
                del pending[future]
                failed.add(fqn)
    done = _ms(t_start)
    complete = sum(1 for fqn, s in state.items() if fqn not in failed and "get" in s and "describe" in s)
    params = sum(len(s.get("names", [])) for s in state.values())
    out = {
        "process_to_start_ms": round((t_start - T0) * 1e3, 1),
        "discovered_ms": discovered,
        "done_ms": done,
        "complete": complete,
        "params": params,
        **ros_graph(node),
    }
    node.destroy_node()
    rclpy.try_shutdown()
    return out


def ros_graph(node: Any) -> dict[str, int]:
    """What the ROS 2 graph holds: topics, services, endpoints (readers + writers, a service
    being a request reader and a reply writer per server, the reverse per client) and DDS
    participants (distinct GID prefixes of the topic endpoints)."""
    topics = node.get_topic_names_and_types()
    services = node.get_service_names_and_types()
    endpoints = 0
    participants: set[bytes] = set()
    for name, _types in topics:
        infos = [*node.get_publishers_info_by_topic(name), *node.get_subscriptions_info_by_topic(name)]
        endpoints += len(infos)
        participants.update(bytes(i.endpoint_gid)[:12] for i in infos)
    for name, _types in services:
        endpoints += 2 * (node.count_services(name) + node.count_clients(name))
    return {
        "topics": len(topics),
        "services": len(services),
        "endpoints": endpoints,
        "participants": len(participants),
    }


def ros_get(fqn: str, name: str) -> dict[str, Any]:
    from rclpy.parameter_client import AsyncParameterClient

    rclpy, node = _ros()
    c = AsyncParameterClient(node, fqn)
    c.wait_for_services(timeout_sec=30.0)
    future = c.get_parameters([name])
    rclpy.spin_until_future_complete(node, future, timeout_sec=30.0)
    reply: Any = future.result()
    value = reply.values[0].double_value
    node.destroy_node()
    rclpy.try_shutdown()
    return {"value": value}


def ros_warm(fqn: str, name: str, count: int) -> dict[str, Any]:
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient

    rclpy, node = _ros()
    c = AsyncParameterClient(node, fqn)
    c.wait_for_services(timeout_sec=30.0)

    def timed(make: Any) -> list[float]:
        out = []
        for i in range(count + count // 10):  # the first tenth warms up
            t = time.perf_counter()
            future = make(i)
            rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
            assert future.done()
            if i >= count // 10:
                out.append((time.perf_counter() - t) * 1e3)
        return out

    gets = timed(lambda _i: c.get_parameters([name]))
    sets = timed(lambda i: c.set_parameters([Parameter(name, value=1.0 + i % 7)]))
    node.destroy_node()
    rclpy.try_shutdown()
    return {"get_ms": gets, "set_ms": sets}


def dds_dump(n: int, prefix: str, timeout: float) -> dict[str, Any]:
    from paramdds.dds.client import ParameterClient
    from paramdds.dds.monitor import ParameterMonitor
    from paramdds.dds.participant import make_participant

    dp = make_participant(int(sys.argv[-1]), localhost=True)
    t_start = time.perf_counter()
    client = ParameterClient(dp)
    monitor = ParameterMonitor(dp)
    wanted = [n.lstrip("/") for n in _names(n, prefix)]
    deadline = t_start + timeout
    while time.perf_counter() < deadline:
        snap = monitor.snapshot()
        states = [snap.get(w) for w in wanted]
        if all(s is not None and (s.complete or not s.online) for s in states):
            break
        settled = client.discovery().settled
        if settled and all(s is None or s.complete or not s.online for s in states):
            break  # what is left was never seen: its host is gone
        time.sleep(0.002)
    done = _ms(t_start)
    snap = monitor.snapshot()
    complete = sum(1 for w in wanted if w in snap and snap[w].online and snap[w].complete)
    params = sum(len(snap[w].parameters) for w in wanted if w in snap)
    return {
        "process_to_start_ms": round((t_start - T0) * 1e3, 1),
        "done_ms": done,
        "complete": complete,
        "params": params,
    }


def dds_warm(node: str, name: str, count: int) -> dict[str, Any]:
    from paramdds.dds.client import ParameterClient
    from paramdds.dds.participant import make_participant

    dp = make_participant(int(sys.argv[-1]), localhost=True)
    client = ParameterClient(dp, timeout=10.0)
    client.wait_for_node(node, timeout=30.0)

    def timed(call: Any) -> list[float]:
        out = []
        for i in range(count + count // 10):
            t = time.perf_counter()
            call(i)
            if i >= count // 10:
                out.append((time.perf_counter() - t) * 1e3)
        return out

    gets = timed(lambda _i: client.get(node, [name]))
    sets = timed(lambda i: client.set(node, {name: 1.0 + i % 7}))
    client.close()
    return {"get_ms": gets, "set_ms": sets}


def dds_graph() -> dict[str, int]:
    """Topics, endpoints and participants of the paramdds system, from the builtin topics
    (endpoints of user topics, this counting participant's own left out)."""
    from paramdds.bench._dds import _builtin_reader, _rows
    from paramdds.dds.participant import make_participant

    dp = make_participant(int(sys.argv[-1]), localhost=True)
    time.sleep(1.0)  # discovery of every endpoint
    rows = [
        s
        for which in ("publication", "subscription")
        for s in _rows(_builtin_reader(dp, which))
        if not s.topic_name.startswith("DCPS") and s.participant_key != dp.guid
    ]
    return {
        "topics": len({s.topic_name for s in rows}),
        "endpoints": len(rows),
        "participants": len({s.participant_key for s in rows}),
    }


def main() -> int:
    mode, args = sys.argv[1], sys.argv[2:]
    if mode == "ros-dump":
        out = ros_dump(int(args[0]), args[1], float(args[2]), float(args[3]))
    elif mode == "ros-get":
        out = ros_get(args[0], args[1])
    elif mode == "ros-warm":
        out = ros_warm(args[0], args[1], int(args[2]))
    elif mode == "dds-dump":
        out = dds_dump(int(args[0]), args[1], float(args[2]))
    elif mode == "dds-graph":
        out = dds_graph()
    elif mode == "dds-warm":
        out = dds_warm(args[0], args[1], int(args[2]))
    else:
        raise SystemExit(f"unknown mode {mode!r}")
    print(json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
