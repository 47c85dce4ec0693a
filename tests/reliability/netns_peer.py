"""The client side of ``test_lossy_network``: run inside the client's network namespace.

``python netns_peer.py NODE REQUESTS``: waits for NODE, interleaves REQUESTS sets
and gets (each checked), then starts a late monitor and waits for the node's full
state. Prints one JSON line with what it saw. Network settings come from
``CYCLONEDDS_URI`` (bound to this namespace's veth address, unicast to the peer).
"""

from __future__ import annotations

import json
import os
import sys
import time


def main() -> int:
    node, requests = sys.argv[1], int(sys.argv[2])
    from paramdds.dds.client import ParameterClient
    from paramdds.dds.monitor import ParameterMonitor
    from paramdds.dds.participant import make_participant

    participant = make_participant(int(os.environ["PARAMDDS_DOMAIN"]))
    client = ParameterClient(participant, timeout=5.0)
    out: dict[str, object] = {"errors": [], "slowest": 0.0}
    errors: list[str] = out["errors"]  # type: ignore[assignment]
    t0 = time.monotonic()
    client.wait_for_node(node, timeout=30)
    out["discovery"] = time.monotonic() - t0
    last = None
    for k in range(requests):
        started = time.monotonic()
        try:
            if k % 2 == 0:
                last = 1000 + k
                reply = client.set(node, {"robot.wheel_count": last, "robot.name": f"n{k}"})
                if not reply.successful:
                    errors.append(f"set {k}: {reply}")
            else:
                got = client.get(node, ["robot.wheel_count"]).values()["robot.wheel_count"].value
                if got != last:
                    errors.append(f"get {k}: {got} != {last}")
        except Exception as exc:
            errors.append(f"request {k}: {type(exc).__name__}: {exc}")
        out["slowest"] = max(out["slowest"], time.monotonic() - started)  # type: ignore[call-overload]
    t1 = time.monotonic()
    monitor = ParameterMonitor(participant)
    complete = monitor.wait_complete([node], timeout=20)
    out["monitor_complete"] = complete
    out["monitor_seconds"] = time.monotonic() - t1
    state = monitor.snapshot().get(node)
    out["monitor_values"] = (
        {n: repr(v.value) for n, (v, _) in state.parameters.items()} if state is not None else {}
    )
    out["last"] = last
    print(json.dumps(out), flush=True)
    monitor.close()
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
