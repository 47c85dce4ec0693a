"""A ROS 2 node is shown with its leading slash (``/arm/driver``) in ``nodes`` (with an origin
column), ``watch`` and their JSON, and accepted with it. The node is hosted as the bridge
hosts a mirror (a real server in this process, presence tag ``origin=ros2``); the CLI
runs as subprocesses on the same domain."""

from __future__ import annotations

import json
import signal
from collections.abc import Iterator

import pytest

from paramdds.core.table import ParameterTable
from paramdds.dds.filters import origin_tag
from paramdds.dds.server import ParameterServer

from ..dds.helpers import DdsSession
from ._support import SEED_PARAMS, Proc, next_domain, run_cli, start_server


@pytest.fixture
def mirror(tmp_path: object) -> Iterator[tuple[int, DdsSession]]:
    domain = next_domain()
    with DdsSession(domain) as dds:
        server = ParameterServer(dds.participant(), tags=[origin_tag("ros2")])
        table = ParameterTable("arm/driver")
        table.declare("gain", 1.5)
        server.add_node(table)
        server.start()
        try:
            yield domain, dds
        finally:
            server.close()


@pytest.mark.slow
def test_a_ros2_node_is_shown_with_its_slash(mirror: tuple[int, DdsSession], tmp_path: object) -> None:
    domain, _ = mirror
    from pathlib import Path

    params = Path(str(tmp_path)) / "p.yaml"
    params.write_text(SEED_PARAMS)
    native = start_server(domain, "-n", "robot1", "-p", str(params))
    watch = Proc(domain, ["watch", "-o", "json", "--prefix", "gain"])
    try:
        listed = json.loads(run_cli(domain, "nodes", "-o", "json").stdout)
        assert [(n["node"], n["origin"]) for n in listed] == [("/arm/driver", "ros2"), ("robot1", None)]
        table: list[str] = []
        for _ in range(5):  # a `nodes` under heavy load may settle before it heard both (CI: once)
            table = run_cli(domain, "nodes").stdout.splitlines()
            if len(table) == 3:
                break
        assert table[0].split() == ["NODE", "ONLINE", "PARAMS", "HOST", "PID", "REVISION", "ORIGIN"]
        assert table[1].split()[0] == "/arm/driver" and table[1].split()[-1] == "ros2"
        assert table[2].split()[0] == "robot1" and table[2].split()[-1] == "paramdds"

        added = json.loads(watch.wait_for('"gain"'))
        assert added["node"] == "/arm/driver"
        one = run_cli(domain, "set", "/arm/driver", "gain", "2.0")
        assert one.returncode == 0, one.stderr
        assert json.loads(watch.wait_for('"modified"'))["node"] == "/arm/driver"
    finally:
        native.stop()
        watch.stop(signal.SIGINT)
