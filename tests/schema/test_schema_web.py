"""``paramdds web --schema NODE=FILE``: the console refuses, before sending, a write the node's
JSON Schema refuses, with the node's own reason. The node here is served WITHOUT the schema
(values from the parameter file only), so a refusal can only come from the console: the same
write sent by the command line is applied. Real processes, real DDS, real HTTP.
"""

from __future__ import annotations

from typing import Any

import httpx
import pytest

from ..cli._support import ROOT, run_cli, start_server
from ..web._support import Console
from ..web.conftest import wait_for_nodes

EXAMPLE = ROOT / "examples" / "autoware"
SCHEMA = EXAMPLE / "schema" / "cruise.schema.json"


def _post(console: Console, route: str, body: dict[str, Any]) -> list[dict[str, Any]]:
    r = httpx.post(console.url + "api/" + route, json=body, timeout=10)
    assert r.status_code == 422, r.text  # some refused: as a node's refusal is answered
    rows: list[dict[str, Any]] = r.json()["results"]
    return rows


@pytest.mark.slow
def test_console_refuses_what_the_schema_refuses_before_sending(domain_id: int) -> None:
    server = start_server(domain_id, "-n", "cruise", "-p", str(EXAMPLE / "config" / "cruise.param.yaml"))
    console = Console(domain_id, "--schema", f"cruise={SCHEMA}")
    try:
        wait_for_nodes(console.url, {"cruise"}, params=6)
        rows = _post(console, "set", {"node": "cruise", "values": {"update_rate": 0.0, "mode": "sport"}})
        assert [(r["name"], r["successful"]) for r in rows] == [("update_rate", False), ("mode", True)]
        assert rows[0]["reason"] == "schema: update_rate: 0.0 is less than or equal to the minimum of 0"
        rows = _post(
            console, "set", {"node": "cruise", "values": {"mode": "race", "update_rate": 5.0}, "atomic": True}
        )
        assert [r["reason"] for r in rows] == [
            "schema: mode: 'race' is not one of ['eco', 'sport']",
            "not applied: the atomic set failed on 'mode'",
        ]
        rows = _post(console, "delete", {"node": "cruise", "names": ["limits.decel"]})
        assert rows[0]["successful"] is False and "'decel' is a required property" in rows[0]["reason"]
        got = run_cli(domain_id, "get", "cruise", "update_rate", "mode")
        assert got.stdout == "update_rate = double 10.0\nmode = string 'sport'\n"
        # the node itself has no schema: only the console refused
        assert run_cli(domain_id, "set", "cruise", "update_rate=0.0").returncode == 0
    finally:
        console.stop()
        server.stop()
