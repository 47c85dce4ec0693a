"""A node that declares its parameters, checks changes in a callback, and serves them.

    PARAMDDS_LOCALHOST=1 python examples/node.py          # then, in another shell:
    PARAMDDS_LOCALHOST=1 paramdds set robot1 robot.max_velocity=2.5
    PARAMDDS_LOCALHOST=1 paramdds set robot1 robot.name=""   # refused by the callback

Domain: PARAMDDS_DOMAIN (default 1). Ctrl-C stops it (monitors see it go offline).
"""

from __future__ import annotations

import os
import time

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.results import SetVeto
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterType
from paramdds.dds.participant import localhost_from_env, make_participant
from paramdds.dds.server import ParameterServer


def build_table() -> ParameterTable:
    table = ParameterTable("robot1")
    table.declare(
        "robot.max_velocity",
        1.5,
        ParameterDescriptor(
            "robot.max_velocity",
            ParameterType.DOUBLE,
            description="top speed in m/s",
            floating_point_range=FloatingPointRange(0.0, 5.0),
        ),
    )
    table.declare("robot.name", "my_robot")
    table.declare("robot.enabled", True)

    def check(params: list[Parameter]) -> SetVeto:
        for p in params:
            if p.name == "robot.name" and not p.value.value:
                return SetVeto(False, "robot.name cannot be empty")
        return SetVeto(True)

    def report(params: list[Parameter]) -> None:
        for p in params:
            print(f"[robot1] {p.name} is now {p.value.show()}", flush=True)

    table.add_on_set_callback(check)
    table.add_post_set_callback(report)
    return table


def main() -> None:
    domain = int(os.environ.get("PARAMDDS_DOMAIN", "1"))
    participant = make_participant(domain, localhost=localhost_from_env(), app_name="example-node")
    server = ParameterServer(participant)
    server.add_node(build_table())
    with server:
        print(f"robot1 serving on domain {domain}; Ctrl-C to stop", flush=True)
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
