"""A client: list, get, set (plain and atomic) and compare-and-set on one node.

PARAMDDS_LOCALHOST=1 python examples/client.py robot1
"""

from __future__ import annotations

import os
import sys

from paramdds.dds.client import ParameterClient
from paramdds.dds.participant import localhost_from_env, make_participant
from paramdds.errors import ParamddsError


def main(node: str) -> int:
    domain = int(os.environ.get("PARAMDDS_DOMAIN", "1"))
    participant = make_participant(domain, localhost=localhost_from_env(), app_name="example-client")
    with ParameterClient(participant, timeout=3.0) as client:
        try:
            client.wait_for_node(node, timeout=5.0)
            names = client.list(node).names
            print(f"{node} has {len(names)} parameters")
            for name, value in client.get(node, names).values().items():
                print(f"  {name} = {value.type.label} {value.show()}")
            reply = client.set(node, {"robot.max_velocity": 2.0})
            for r in reply.results:
                print(f"set {r.name}: {'ok' if r.successful else r.reason} (revision {reply.revision})")
            # all or nothing: the second value has the wrong type, so neither is applied
            reply = client.set(node, {"robot.max_velocity": 1.0, "robot.enabled": "yes"}, atomic=True)
            print(f"atomic set applied: {reply.successful}")
            # compare-and-set: only applies while nobody else changed the node
            reply = client.set(node, {"robot.max_velocity": 3.0}, if_revision=reply.revision)
            print(f"compare-and-set applied: {reply.successful}")
        except ParamddsError as exc:
            print(f"error ({exc.code.value}): {exc}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "robot1"))
