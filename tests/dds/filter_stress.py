"""Bursts in one process: two servers, three clients and a raw flooder on one participant.

Run by ``test_integration_filtering`` as ``python -m tests.dds.filter_stress`` (domain from
``PARAMDDS_DOMAIN``) under a hard timeout: writes to the process's own filtered readers
deliver locally, on the writing thread, while dispatch threads take. This is the shape in
which a Python topic filter deadlocked the binding. Prints one JSON line of counts.
"""

from __future__ import annotations

import asyncio
import json
import os
import threading
from typing import Any

from cyclonedds.pub import DataWriter

from paramdds.core.table import ParameterTable
from paramdds.core.values import ParameterValue
from paramdds.dds.client import AsyncParameterClient, ParameterClient
from paramdds.dds.participant import make_participant
from paramdds.dds.qos import QosProfiles
from paramdds.dds.server import ParameterServer
from paramdds.dds.topics import make_topic
from paramdds.dds.wire import types as wire

NODES = [f"n{i}" for i in range(8)]
ROUNDS = 20
FLOOD_BATCH = 500


def main() -> dict[str, Any]:
    dp = make_participant(int(os.environ["PARAMDDS_DOMAIN"]), localhost=True)
    servers = []
    for k in range(2):
        server = ParameterServer(dp)
        for node in NODES[k::2]:
            t = ParameterTable(node)
            t.declare("v", ParameterValue.from_python(0))
            server.add_node(t)
        servers.append(server.start())
    clients = [ParameterClient(dp, timeout=20.0) for _ in range(3)]
    qos = QosProfiles.load()
    writer = DataWriter(
        dp,
        make_topic(dp, "GetParametersRequest", wire.GetParametersRequest),
        qos.writer("GetParametersRequest"),
    )
    errors: list[str] = []
    replies = [0]
    flooded = [0]
    stop = threading.Event()

    def flood() -> None:
        while not stop.is_set():
            for i in range(FLOOD_BATCH):
                writer.write(wire.GetParametersRequest(node_id="nobody", client_id=9, request_id=i + 1))
            flooded[0] += FLOOD_BATCH

    async def burst(client: ParameterClient, k: int) -> None:
        ac = AsyncParameterClient(client)
        for round_ in range(ROUNDS):
            calls = [ac.set(n, {"v": k * 1000 + round_}) for n in NODES] + [ac.get(n, ["v"]) for n in NODES]
            for reply in await asyncio.gather(*calls):
                replies[0] += 1
                if reply.node not in NODES:
                    errors.append(f"reply for {reply.node}")

    def run(client: ParameterClient, k: int) -> None:
        try:
            asyncio.run(burst(client, k))
        except Exception as exc:
            errors.append(f"client {k}: {type(exc).__name__}: {exc}")

    flooder = threading.Thread(target=flood, daemon=True)
    workers = [threading.Thread(target=run, args=(c, k), daemon=True) for k, c in enumerate(clients)]
    flooder.start()
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    stop.set()
    flooder.join()
    for c in clients:
        c.close()
    for s in servers:
        s.close()
    return {
        "errors": errors,
        "calls": len(clients) * ROUNDS * 2 * len(NODES),
        "replies": replies[0],
        "flooded": flooded[0],
        "rejected": sum(s.filter.counts()[1] for s in servers),
        "foreign_seen": sum(s.foreign_requests for s in servers),
    }


if __name__ == "__main__":
    print(json.dumps(main()), flush=True)
