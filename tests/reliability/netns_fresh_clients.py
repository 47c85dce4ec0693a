"""Fresh API clients, one after another: run inside the client's network namespace.

``python netns_fresh_clients.py NODE NAME VALUE ROUNDS``: each round creates a new
participant (so discovery starts from nothing: the process's last participant is
gone, and Cyclone with it), a :class:`ParameterClient` with its default presence
rule, and either waits for NODE (``wait_for_node``, even rounds) or calls ``get`` at
once (odd rounds), then reads NAME and checks it equals VALUE. Prints one JSON line:
``{"errors": [...], "seconds": [...]}``. Network settings come from ``CYCLONEDDS_URI``.
"""

from __future__ import annotations

import json
import os
import sys
import time


def main() -> int:
    node, name, value, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    from paramdds.dds.client import ParameterClient
    from paramdds.dds.participant import close_participant, make_participant

    domain = int(os.environ["PARAMDDS_DOMAIN"])
    errors: list[str] = []
    seconds: list[float] = []
    for k in range(rounds):
        started = time.monotonic()
        participant = make_participant(domain)
        client = ParameterClient(participant, timeout=10.0)
        try:
            if k % 2 == 0:
                client.wait_for_node(node, timeout=10.0)
            got = client.get_value(node, name).value
            if got != value:
                errors.append(f"round {k}: {got!r} != {value!r}")
        except Exception as exc:
            errors.append(f"round {k}: {type(exc).__name__}: {exc}")
        finally:
            client.close()
            close_participant(participant)
        seconds.append(time.monotonic() - started)
    print(json.dumps({"errors": errors, "seconds": seconds}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
