"""Bench worker processes: ``python -m paramdds.bench.worker ROLE [options]``.

Roles (see :mod:`paramdds.bench._common` for the READY / RESULT protocol):

``server``   host ``--nodes`` node ids with ``--params`` parameters each, either
             with paramdds's :class:`~paramdds.dds.server.ParameterServer`
             (``--layout paramdds``) or in the ROS 2 layout (``--layout ros``);
``echo``     the raw echo server of the latency and throughput baselines;
``monitor``  start, time until the full state of every node is held, report, exit;
``census``   count topics and endpoints in the domain with the builtin topics;
``load``     a throughput client: keep ``--window`` gets (or echoes) in flight;
``partition`` the partition-per-node alternative (fleet bench): a request reader
             whose subscriber's partitions are the hosted node ids;
``setter``   a client of ``bench persist``: on ``wait`` it waits until ``--node`` answers
             (then ``RESULT {}``), on ``go {json}`` it sets from the job's ``start`` until its
             ``end`` (``time.monotonic()``, the same clock in every process) and reports
             ``RESULT {"sets": n, "finished": t}`` (or ``{"error": …}``).

A worker exits when its stdin closes or on SIGTERM, closing its DDS entities.
"""

from __future__ import annotations

import time

T_EXEC = time.perf_counter_ns()  # before the heavy imports

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
from typing import Any  # noqa: E402


def _ms(a: int, b: int) -> float:
    return (b - a) / 1e6


def _say(tag: str, **data: Any) -> None:
    sys.stdout.write(f"{tag} {json.dumps(data)}\n")
    sys.stdout.flush()


def _wait_for_stdin_eof() -> None:
    try:
        while sys.stdin.readline():
            pass
    except (OSError, ValueError):
        pass


def _on_sigterm(_signum: int, _frame: Any) -> None:
    raise SystemExit(0)


# The benchmark parameter set, in the proportions of real ROS 2 files (/work/shared/realworld:
# 617 values of five parameter files: 36 % double, 29 % string, 15 % bool, 11 % int, 8 % arrays;
# 122 parameters of four generate_parameter_library specs: 82 % described, 34 % validated,
# 28 % read-only). Per 20 parameters: 7 double, 6 string, 3 bool, 2 int, a string array and a
# double array; 16 described, 7 with a range or validators, 5 read-only (all at j % 20 >= 12,
# so the latency bench's set of parameters 0..9 only touches writable ones).
_KINDS = "dibdssdsbdsidsbdsdSD"  # d double, s string, b bool, i int, S string[], D double[]
# (slot 1 is an integer: the web bench sets group0.param_001 to integers)
_READ_ONLY = {12, 13, 14, 16, 18}


def value_for(j: int, salt: int = 0) -> object:
    """The value of parameter ``j`` (its type depends on j only; ``salt`` varies it)."""
    kind = _KINDS[j % 20]
    if kind == "d":
        return float(j) + salt * 0.001
    if kind == "i":
        return j + salt
    if kind == "s":
        return f"value_{j}_{salt}"
    if kind == "b":
        return bool((j + salt) % 2)
    if kind == "S":
        return [f"frame_{j}", f"link_{salt}"]
    return [float(j), salt * 0.5, 1.0]


def param_name(j: int) -> str:
    return f"group{j // 10}.param_{j:03d}"


def descriptor_for(j: int) -> Any:
    """Parameter ``j``'s descriptor: what a generate_parameter_library spec would declare."""
    from ..core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
    from ..core.values import ParameterValue

    def v(x: object) -> ParameterValue:
        return ParameterValue.from_python(x)

    slot = j % 20
    described = slot % 5 != 4
    fields: dict[str, Any] = {
        "description": f"{'Gain' if _KINDS[slot] == 'd' else 'Setting'} {j} of the controller, "
        "as the spec file documents it"
        if described
        else "",
        "read_only": slot in _READ_ONLY,
    }
    if slot in (0, 3, 6):
        fields["floating_point_range"] = FloatingPointRange(-1.0e6, 1.0e6)
    elif slot == 1:
        fields["integer_range"] = IntegerRange(0, 1_000_000_000)
    elif slot == 16:
        fields["validators"] = (Validator("one_of", (v([str(value_for(j)), "other"]),)),)
    elif slot == 18:
        fields["validators"] = (Validator("not_empty"), Validator("unique"))
    elif slot == 19:
        fields["validators"] = (Validator("element_bounds", (v(-1.0e6), v(1.0e6))),)
    return ParameterDescriptor(param_name(j), **fields)


def make_table(node: str, params: int) -> Any:
    from ..core.table import ParameterTable
    from ..core.values import ParameterValue

    table = ParameterTable(node)
    table.declare_from(
        (param_name(j), ParameterValue.from_python(value_for(j)), descriptor_for(j)) for j in range(params)
    )
    return table


_participants: list[Any] = []


def _participant(args: argparse.Namespace, *, topic_discovery: bool = False) -> Any:
    from ..dds.participant import make_participant

    dp = make_participant(
        args.domain, localhost=args.localhost, app_name=f"bench-{args.role}", topic_discovery=topic_discovery
    )
    _participants.append(dp)
    return dp


def _delete_participants() -> None:
    """Delete our participants before exit: peers then drop them at once instead of after
    the 10 s lease, during which their reliable writers would keep data for our readers."""
    from cyclonedds.core import Entity

    while _participants:
        Entity.__del__(_participants.pop())


def role_server(args: argparse.Namespace) -> None:
    from ..dds.qos import QosProfiles
    from ._common import node_names

    t_import = time.perf_counter_ns()
    qos = QosProfiles.load()
    dp = _participant(args, topic_discovery=args.topic_discovery)
    names = node_names(args.offset + args.nodes)[args.offset :]
    if args.no_native_filter:
        from ..dds.filters import disable_native

        disable_native()
    server: Any
    if args.layout == "ros":
        from ._dds import RosLayoutServer

        server = RosLayoutServer(dp, qos)
    else:
        from ..dds.server import ParameterServer

        server = ParameterServer(dp, qos)
    tables = {node: make_table(node, args.params) for node in names}
    for table in tables.values():
        server.add_node(table)
    server.start()
    t_ready = time.perf_counter_ns()
    _say("READY", pid=os.getpid(), import_ms=_ms(T_EXEC, t_import), setup_ms=_ms(t_import, t_ready))
    try:
        if args.changes:
            _change_on_stdin(tables)
        else:
            _wait_for_stdin_eof()
    finally:
        server.close()


def _change_on_stdin(tables: dict[str, Any]) -> None:
    """``server --changes``: each stdin line ``NODE NAME VALUE`` sets a double parameter in
    this process (a change made on the site, as a node's own code makes it), then ``CHANGED``."""
    from ..core.values import Parameter, ParameterType, ParameterValue

    for line in sys.stdin:
        node, name, value = line.split()
        outcome = tables[node].set([Parameter(name, ParameterValue.of(ParameterType.DOUBLE, float(value)))])
        _say("CHANGED", ok=all(r.successful for r in outcome.results))


def role_partition(args: argparse.Namespace) -> None:
    """The alternative layout (measured, not adopted): one request reader whose subscriber's
    partitions are the node ids hosted, so requests for other nodes never reach this process."""
    from cyclonedds.qos import Policy, Qos
    from cyclonedds.sub import DataReader, Subscriber

    from ..dds.dispatch import Dispatcher
    from ..dds.qos import QosProfiles
    from ..dds.topics import make_topic
    from ..dds.wire import types as wire
    from ._common import NODE_PREFIX, node_names

    qos = QosProfiles.load()
    dp = _participant(args)
    # a wildcard reads every node's partition (a monitor's form); Cyclone 11.0.1's binding
    # crashed with 10,000 partition names on one subscriber (1,000 work)
    names = [f"{NODE_PREFIX}*"] if args.wildcard else node_names(args.offset + args.nodes)[args.offset :]
    subscriber = Subscriber(dp, qos=Qos(Policy.Partition(partitions=names)))
    topic = make_topic(dp, "GetParametersRequest", wire.GetParametersRequest)
    reader = DataReader(subscriber, topic, qos.reader("GetParametersRequest"))
    dispatcher = Dispatcher(dp, "bench-partition")
    dispatcher.add_raw(reader, lambda data, _info: data, lambda _samples: None)
    dispatcher.start()
    _say("READY", pid=os.getpid())
    try:
        _wait_for_stdin_eof()
    finally:
        dispatcher.close()


def role_echo(args: argparse.Namespace) -> None:
    from ..dds.qos import QosProfiles
    from ._dds import serve_echo

    qos = QosProfiles.load()
    dp = _participant(args)
    dispatcher = serve_echo(dp, qos, args.reply_size)
    _say("READY", pid=os.getpid())
    try:
        _wait_for_stdin_eof()
    finally:
        dispatcher.close()


def role_monitor(args: argparse.Namespace) -> None:
    from ..dds.qos import QosProfiles
    from ._common import node_names

    if args.layout == "ros":
        from ._dds import RosLayoutMonitor, own_endpoints
    else:
        from ..dds.monitor import ParameterMonitor
        from ._dds import own_endpoints
    qos = QosProfiles.load()
    nodes = node_names(args.nodes)
    t_import = time.perf_counter_ns()
    dp = _participant(args)
    t_dp = time.perf_counter_ns()
    if args.layout == "ros":
        monitor = RosLayoutMonitor(dp, qos, nodes)
        state = monitor.run(args.timeout)
        t_done = time.perf_counter_ns()
        params = sum(len(v) for v in state.values())
        described = sum(1 for v in state.values() for _val, d in v.values() if d)
    else:
        pm = ParameterMonitor(dp, qos)
        if not pm.wait_complete(nodes, args.timeout):
            snap = pm.snapshot()
            have = sum(1 for n in nodes if n in snap and snap[n].complete)
            raise SystemExit(f"monitor: {have} of {len(nodes)} nodes complete after {args.timeout:g} s")
        t_done = time.perf_counter_ns()
        snap = pm.snapshot()
        params = sum(len(snap[n].parameters) for n in nodes)
        described = params
    endpoints = own_endpoints(dp)
    _say(
        "RESULT",
        pid=os.getpid(),
        import_ms=_ms(T_EXEC, t_import),
        participant_ms=_ms(t_import, t_dp),
        full_state_ms=_ms(t_dp, t_done),
        resends=monitor.resends if args.layout == "ros" else 0,
        params=params,
        described=described,
        endpoints=endpoints,
    )
    if args.layout != "ros":
        if args.stay:  # a viewer: it keeps the state (and receives every change) until stdin closes
            _wait_for_stdin_eof()
        pm.close()


def role_census(args: argparse.Namespace) -> None:
    from ._dds import census

    dp = _participant(args, topic_discovery=True)
    _say("RESULT", **census(dp, settle=args.settle))


def role_load(args: argparse.Namespace) -> None:
    """``window`` asyncio tasks, each awaiting one request after another, for ``seconds``.

    Gets go through the public :class:`~paramdds.dds.client.AsyncParameterClient`;
    echoes through the same Future → ``asyncio.wrap_future`` path.
    """
    import asyncio

    from ..dds.qos import QosProfiles
    from ..errors import ParamddsError

    qos = QosProfiles.load()
    dp = _participant(args)
    if args.kind == "echo":
        from ._dds import EchoClient

        echo = EchoClient(dp, qos, args.request_size)
        if not echo.wait_matched(10.0):
            raise SystemExit("load: the echo server did not match")

        async def one() -> None:
            await asyncio.wait_for(asyncio.wrap_future(echo.send()), 5.0)

        closer: Any = echo
    else:
        from ..dds.client import AsyncParameterClient, ParameterClient

        client = ParameterClient(dp, qos)
        client.wait_for_node(args.node, 10.0)
        aclient = AsyncParameterClient(client)
        names = [param_name(0)]

        async def one() -> None:
            await aclient.get(args.node, names)

        closer = client
    # A reply writer may match this client's reply reader a little after this client
    # matched the request reader: replies sent before that are lost (VOLATILE). Probe
    # with one request at a time until one is answered, then open the window.
    deadline = time.monotonic() + 20.0
    while True:
        try:
            if args.kind == "echo":
                echo.call(timeout=0.5)
            else:
                client.get(args.node, names, timeout=0.5)
            break
        except Exception:
            if time.monotonic() > deadline:
                raise
    counts = {"done": 0, "measuring": False, "stop": False, "lost": 0}

    async def worker() -> None:
        while not counts["stop"]:
            try:
                await one()
            except (asyncio.TimeoutError, TimeoutError, ParamddsError):
                counts["lost"] += 1  # unanswered within 5 s: reported, and the task goes on
                continue
            if counts["measuring"]:
                counts["done"] += 1

    async def drive() -> dict[str, float]:
        tasks = [asyncio.create_task(worker()) for _ in range(args.window)]
        await asyncio.sleep(args.warmup)
        counts["measuring"] = True
        t0 = time.perf_counter_ns()
        await asyncio.sleep(args.seconds)
        counts["measuring"] = False
        t1 = time.perf_counter_ns()
        done = counts["done"]
        counts["stop"] = True
        await asyncio.wait_for(asyncio.gather(*tasks), 30.0)
        return {"per_s": done / ((t1 - t0) / 1e9), "completed": done, "lost": counts["lost"]}

    _say("READY", pid=os.getpid())
    go = sys.stdin.readline()  # the bench starts every load worker at once
    if go.strip() != "go":
        return
    try:
        _say("RESULT", **asyncio.run(drive()))
    finally:
        closer.close()


def role_setter(args: argparse.Namespace) -> None:
    from ..dds.client import ParameterClient
    from ..errors import ParamddsError
    from .persist import set_until

    # lazy presence, as the CLI's one-shot verbs: no presence reader, so the node's state
    # samples (one per set) are not sent to this process too
    client = ParameterClient(_participant(args), timeout=10.0, one_shot=True)
    _say("READY", pid=os.getpid())
    try:
        for line in sys.stdin:
            word, _, rest = line.strip().partition(" ")
            if word == "wait":  # until the node (a server started for this round) answers
                deadline = time.monotonic() + 20.0
                while True:
                    try:
                        client.list(args.node, timeout=0.5)
                        break
                    except ParamddsError:
                        if time.monotonic() > deadline:
                            raise
                _say("RESULT")
            elif word == "go":
                job = json.loads(rest)
                time.sleep(max(0.0, job["start"] - time.monotonic()))
                try:
                    sets = set_until(client, job["count"], job["lane"], job["lanes"], job["end"])
                except Exception as exc:  # reported to the bench, which fails the run with it
                    _say("RESULT", error=f"{type(exc).__name__}: {exc}")
                    continue
                _say("RESULT", sets=sets, finished=time.monotonic())
    finally:
        client.close()


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m paramdds.bench.worker")
    p.add_argument("role", choices=("server", "echo", "monitor", "census", "load", "partition", "setter"))
    p.add_argument("-d", "--domain", type=int, required=True)
    p.add_argument("--localhost", action="store_true")
    p.add_argument("--layout", choices=("paramdds", "ros"), default="paramdds")
    p.add_argument("--nodes", type=int, default=1)
    p.add_argument("--offset", type=int, default=0)
    p.add_argument("--params", type=int, default=50)
    p.add_argument("--topic-discovery", action="store_true")
    p.add_argument("--changes", action="store_true", help="server: set parameters as stdin says")
    p.add_argument("--stay", action="store_true", help="monitor: stay, holding the state, until stdin closes")
    p.add_argument("--no-native-filter", action="store_true", help="server: filter in the handlers only")
    p.add_argument("--wildcard", action="store_true", help="partition: every node's partition")
    p.add_argument("--reply-size", type=int, default=100)
    p.add_argument("--request-size", type=int, default=100)
    p.add_argument("--timeout", type=float, default=60.0)
    p.add_argument("--settle", type=float, default=0.3)
    p.add_argument("--kind", choices=("get", "echo"), default="get")
    p.add_argument("--node", default="bench_n0000")
    p.add_argument("--window", type=int, default=32)
    p.add_argument("--warmup", type=float, default=0.5)
    p.add_argument("--seconds", type=float, default=2.0)
    args = p.parse_args(argv)
    signal.signal(signal.SIGTERM, _on_sigterm)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the bench process decides when we stop
    try:
        {
            "server": role_server,
            "echo": role_echo,
            "monitor": role_monitor,
            "census": role_census,
            "load": role_load,
            "partition": role_partition,
            "setter": role_setter,
        }[args.role](args)
    finally:
        _delete_participants()
    sys.stdout.flush()


if __name__ == "__main__":
    main()
