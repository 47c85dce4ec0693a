"""``POST /api/validate``: the node's own rules and words, from the descriptors the console holds.

The page asks it as the user edits (no validator is written in the browser); it sends
nothing to the node, so the node's revision and values stay as they were.
"""

from __future__ import annotations

import json

import httpx

from ..cli._support import run_cli
from ._support import Console

JSON = {"Content-Type": "application/json"}


def validate(console: Console, body: object, **headers: str) -> httpx.Response:
    data = json.dumps(body)
    return httpx.post(console.url + "api/validate", content=data, headers={**JSON, **headers}, timeout=10)


def summary(console: Console, node: str) -> dict[str, object]:
    r = httpx.get(console.url + "api/node", params={"node": node}, timeout=5)
    assert r.status_code == 200, r.text
    body: dict[str, object] = r.json()
    return body


def test_each_value_gets_the_nodes_verdict_in_the_order_asked(console: Console, domain: int) -> None:
    before = summary(console, "arm")
    values = {
        "speed": 9.5,  # floating_point_range [0.0, 5.0]
        "gain": 3,  # valid (integer_range [0, 10, 1])
        "limits": [1.0, 11.0],  # element_bounds [0.0, 10.0]
        "tags": ["front", "front"],  # unique
        "mode": "fast",  # one_of
        "key": "0g",  # not hex
        "speed2": "anything",  # undeclared here: typed by its JSON, nothing to check
        "bad name!": 1,
    }
    r = validate(console, {"node": "arm", "values": values})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["node"] == "arm"
    results = body["results"]
    assert [x["name"] for x in results] == list(values)
    verdicts = {x["name"]: (x["valid"], x["code"]) for x in results}
    assert verdicts == {
        "speed": (False, "OUT_OF_RANGE"),
        "gain": (True, None),
        "limits": (False, "OUT_OF_RANGE"),
        "tags": (False, "INVALID_VALUE"),
        "mode": (False, "INVALID_VALUE"),
        "key": (False, "TYPE_MISMATCH"),
        "speed2": (True, None),
        "bad name!": (False, "INVALID_NAME"),
    }
    assert all(x["reason"] == "" for x in results if x["valid"])
    # the words are the node's own: what it answers when asked directly
    reasons = {x["name"]: x["reason"] for x in results}
    asked = {"speed": "speed=9.5", "limits": "limits=[1.0, 11.0]", "tags": "tags=[front, front]"}
    for name, cli in asked.items():
        direct = run_cli(domain, "set", "arm", cli)
        assert direct.returncode == 1
        assert reasons[name] in direct.stdout + direct.stderr
    assert summary(console, "arm") == before  # nothing was sent


def test_bad_requests_are_refused_with_a_code(console: Console) -> None:
    unknown = validate(console, {"node": "ghost", "values": {"speed": 1.0}})
    assert (unknown.status_code, unknown.json()["error"]["code"]) == (404, "NOT_FOUND")
    empty = validate(console, {"node": "arm", "values": {}})
    assert (empty.status_code, empty.json()["error"]["code"]) == (400, "BAD_REQUEST")
    form = httpx.post(console.url + "api/validate", content="node=arm", timeout=5)
    assert (form.status_code, form.json()["error"]["code"]) == (415, "UNSUPPORTED_MEDIA")
    ok = validate(console, {"node": "base", "values": {"speed": 2.0}})
    assert ok.json()["results"] == [{"name": "speed", "valid": True, "reason": "", "code": None}]


def test_the_schema_lists_the_route(console: Console) -> None:
    schema = httpx.get(console.url + "api/openapi.json", timeout=5).json()
    assert "post" in schema["paths"]["/api/validate"]
