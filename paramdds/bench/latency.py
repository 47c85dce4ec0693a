"""``paramdds bench latency``: round trips of a get and of a set of 10 parameters.

This process is the client; the paramdds server and the raw echo peer are worker
processes. Measured systems, alternated in rounds (the order rotates each round)
so that drift and noise from other load hit every system alike:

* ``get``     :meth:`ParameterClient.get` of one parameter;
* ``set``     :meth:`ParameterClient.set` of 10 parameters (real changes: the
              server also publishes 10 state samples and the presence after the reply);
* ``raw``     a raw echo over cyclonedds Python, request and reply of the same
              serialized size as the get, same QoS profiles, same wake-up (a WaitSet
              dispatcher thread completing a Future), separate process: the floor;
* ``polling`` a polling client (the design paramdds replaced): the same get to the same
              server, the reply found by taking and sleeping 10 ms between attempts
              (fewer requests: each costs ~10 ms).

``--viewers V`` starts V monitor processes that hold the node's state while it is
measured (as a web console or ``paramdds watch`` would): every set's state samples then
also go to each of them.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from ._common import Workers, alternate, emit, node_names, note, percentile, render
from .worker import param_name, value_for

NODE = node_names(1)[0]
PARAMS = 50


def run(args: argparse.Namespace) -> int:
    quick = args.quick
    requests = args.requests or (200 if quick else 2000)
    rounds = args.rounds or (4 if quick else 10)
    polling = min(max(rounds, requests // 10), 20 if quick else 200)
    warmup = 50 if quick else 300

    from ..dds.client import ParameterClient
    from ..dds.participant import make_participant
    from ..dds.qos import QosProfiles
    from ._dds import EchoClient, PollingClient, get_sizes, wait_matched

    req_size, rep_size = get_sizes(NODE, param_name(0), value_for(0))
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        server = workers.start("server", "--nodes", "1", "--params", str(PARAMS))
        echo = workers.start("echo", "--reply-size", str(rep_size))
        server.read("READY", 60)
        echo.read("READY", 60)
        viewers = [workers.start("monitor", "--nodes", "1", "--stay") for _ in range(args.viewers or 0)]
        for viewer in viewers:
            viewer.read("RESULT", 60)
        qos = QosProfiles.load()
        dp = make_participant(args.domain, localhost=args.localhost, app_name="bench-latency")
        client = ParameterClient(dp, qos)
        raw = EchoClient(dp, qos, req_size)
        poller = PollingClient(dp, qos)
        try:
            client.wait_for_node(NODE, 10.0)
            if not raw.wait_matched(10.0) or not wait_matched([poller._writer], [poller._reader], 10.0):
                raise RuntimeError("the raw echo or polling endpoints did not match")
            salt = [0]
            get_names = [param_name(0)]
            set_names = [param_name(j) for j in range(10)]

            def do_get() -> None:
                client.get(NODE, get_names)

            def do_set() -> None:
                salt[0] += 1
                reply = client.set(NODE, {n: value_for(j, salt[0]) for j, n in enumerate(set_names)})
                if not reply.successful:
                    raise RuntimeError(f"set refused: {reply.results}")

            def do_raw() -> None:
                raw.call()

            def do_poll() -> None:
                poller.get(NODE, get_names)

            systems: dict[str, tuple[Callable[[], None], int]] = {
                "get": (do_get, requests),
                "set": (do_set, requests),
                "raw": (do_raw, requests),
                "polling": (do_poll, polling),
            }
            note(f"latency: warm-up, then {requests} requests per system in {rounds} alternating rounds")
            for name, (fn, _) in systems.items():
                for _ in range(warmup if name != "polling" else 3):
                    fn()
            samples = alternate(systems, rounds)
        finally:
            client.close()
            raw.close()

    def p(name: str, q: float) -> float:
        return round(percentile(samples[name], q), 1)

    data = {
        "get_p50_us": p("get", 50),
        "get_p99_us": p("get", 99),
        "set_p50_us": p("set", 50),
        "set_p99_us": p("set", 99),
        "raw_p50_us": p("raw", 50),
        "raw_p99_us": p("raw", 99),
        "polling_p50_us": p("polling", 50),
        "polling_p99_us": p("polling", 99),
        "ratio_get_raw": round(percentile(samples["get"], 50) / percentile(samples["raw"], 50), 3),
        "ratio_set_raw": round(percentile(samples["set"], 50) / percentile(samples["raw"], 50), 3),
        "ratio_polling_get": round(percentile(samples["polling"], 50) / percentile(samples["get"], 50), 1),
        "requests": requests,
        "polling_requests": polling,
        "rounds": rounds,
        "viewers": len(viewers),
        "request_bytes": req_size,
        "reply_bytes": rep_size,
        "get_mean_us": round(sum(samples["get"]) / len(samples["get"]), 1),
    }
    rows = [
        ("get (1 param)", data["get_p50_us"], data["get_p99_us"], data["ratio_get_raw"], requests),
        ("set (10 params)", data["set_p50_us"], data["set_p99_us"], data["ratio_set_raw"], requests),
        ("raw echo (floor)", data["raw_p50_us"], data["raw_p99_us"], 1.0, requests),
        (
            "polling 10 ms (seed)",
            data["polling_p50_us"],
            data["polling_p99_us"],
            round(percentile(samples["polling"], 50) / percentile(samples["raw"], 50), 1),
            polling,
        ),
    ]
    table = render(["system", "p50 µs", "p99 µs", "p50 / raw", "requests"], rows)
    table += (
        f"\n\npayload: request {req_size} B, reply {rep_size} B; "
        f"polling p50 / get p50 = {data['ratio_polling_get']}x; {len(viewers)} viewer process(es)"
    )
    emit(args, data, table)
    return 0
