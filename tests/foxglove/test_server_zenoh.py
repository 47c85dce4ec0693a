"""`paramdds foxglove --zenoh`: a fleet's nodes, named /site/node.param, read and set through a router."""

from __future__ import annotations

import asyncio
import json

import pytest

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .test_server import READY, ask, opened, replied, until, until_each

pytest.importorskip("zenoh", reason="the zenoh extra is not installed (pip install -e '.[zenoh]')")

from ..zenoh.conftest import Fleet


def test_a_fleet_through_zenoh(fleet: Fleet) -> None:
    fleet.server("s1", "arm", spec=False)
    fleet.gateway("s1")
    proc = Proc(
        [PARAMDDS, "foxglove", "--port", "0", "--zenoh", fleet.endpoint, "--timeout", "5"],
        make_dds_env(fleet.domain("elsewhere")),
    )
    fleet.procs.append(proc)
    _, line = proc.wait_for(READY, 30)
    assert line.endswith("(1 node)"), line
    url = line.split(" on ", 1)[1].split(" ", 1)[0]

    async def go() -> None:
        ws = await opened(url)
        await ask(ws, {"op": "getParameters", "parameterNames": [], "id": "all"})
        got = {p["name"]: p for p in (await until(ws, replied("all")))["parameters"]}
        assert got["/s1/arm.robot.max_velocity"] == {
            "name": "/s1/arm.robot.max_velocity",
            "value": 1.5,
            "type": "float64",
        }
        await ask(ws, {"op": "subscribeParameterUpdates", "parameterNames": ["/s1/arm.robot.max_velocity"]})
        await ask(
            ws,
            {
                "op": "setParameters",
                "id": "s",
                "parameters": [{"name": "/s1/arm.robot.max_velocity", "value": 2, "type": "float64"}],
            },
        )
        pushes = lambda m: m.get("op") == "parameterValues" and "id" not in m  # noqa: E731
        got = await until_each(ws, {"echo": replied("s"), "push": pushes}, timeout=15)  # in either order
        echoed, pushed = got["echo"], got["push"]
        assert echoed["parameters"] == [
            {"name": "/s1/arm.robot.max_velocity", "value": 2.0, "type": "float64"}
        ]
        assert json.dumps(pushed["parameters"]) == json.dumps(echoed["parameters"])
        await ws.close()

    asyncio.run(go())
