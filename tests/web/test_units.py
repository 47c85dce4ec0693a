"""Pure parts of the console, without DDS or HTTP: the status table, value typing, options, the hub."""

from __future__ import annotations

import argparse
import asyncio
import json
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.errors import ErrorCode, OutOfRangeError, TypeMismatchError
from paramdds.exits import UsageError
from paramdds.listen import is_loopback
from paramdds.web.hub import Hub
from paramdds.web.model import atomic_refusal, choices, parameter_row, typed_parameters, typed_value
from paramdds.web.serve import options_from, parse_bind
from paramdds.web.status import STATUS, WebCode, status_of
from paramdds.web.view import StateView

SPEED = ParameterDescriptor("speed", ParameterType.DOUBLE, floating_point_range=FloatingPointRange(0.0, 5.0))


def test_every_error_code_has_a_4xx_or_5xx_status() -> None:
    for code in [*ErrorCode, *WebCode]:
        assert code.value in STATUS and 400 <= STATUS[code.value] < 600, code
    assert (status_of("NOT_FOUND"), status_of("READ_ONLY"), status_of("CONFLICT")) == (404, 403, 409)
    assert (status_of("OUT_OF_RANGE"), status_of("UNAVAILABLE"), status_of("TIMEOUT")) == (422, 503, 504)


def test_a_double_takes_an_integer_and_the_non_finite_words() -> None:
    assert typed_value("speed", 2, SPEED) == ParameterValue(ParameterType.DOUBLE, 2.0)
    free = ParameterDescriptor("x", ParameterType.DOUBLE)
    assert math.isinf(typed_value("x", "-inf", free).value)  # type: ignore[arg-type]
    with pytest.raises(OutOfRangeError, match=r"must be within \[0.0, 5.0\]"):
        typed_value("speed", 5.5, SPEED)
    with pytest.raises(TypeMismatchError):
        typed_value("speed", True, SPEED)


def test_bytes_from_hex_or_ints() -> None:
    key = ParameterDescriptor("key", ParameterType.BYTE_ARRAY)
    assert typed_value("key", "0a FF", key).value == b"\x0a\xff"
    assert typed_value("key", [1, 2], key).value == b"\x01\x02"
    with pytest.raises(TypeMismatchError, match="hex"):
        typed_value("key", "abc", key)


def test_each_value_of_a_request_is_typed_or_refused_with_its_code() -> None:
    described = {"speed": (ParameterValue(ParameterType.DOUBLE, 1.0), SPEED)}
    params, refused = typed_parameters({"speed": 9.5, "other": 1, "bad name!": 2}, described)
    assert [p.name for p in params] == ["other"]
    assert [(r["name"], r["successful"], r["code"]) for r in refused] == [
        ("speed", False, "OUT_OF_RANGE"),
        ("bad name!", False, "INVALID_NAME"),
    ]


def test_an_atomic_refusal_has_a_row_per_name_in_the_nodes_words() -> None:
    cause = {"name": "b", "successful": False, "reason": "too big", "code": "OUT_OF_RANGE"}
    same = {"name": "c", "successful": True, "reason": "unchanged", "code": None}
    rows = atomic_refusal(["a", "b", "c"], [cause, same])
    other = "not applied: the atomic set failed on 'b'"
    assert rows == [{"name": "a", "successful": False, "reason": other, "code": "INVALID_VALUE"}, cause, same]


def _choices_of(descriptor: ParameterDescriptor) -> object:
    return parameter_row(descriptor.name, _a_value(descriptor.type), descriptor)["choices"]


def _a_value(ptype: ParameterType) -> ParameterValue:
    return ParameterValue.of(ptype, {"string": "x", "integer": 1, "double": 1.0}.get(ptype.label, ["x"]))


def test_a_gpl_one_of_and_a_schema_enum_both_give_a_choice_list() -> None:
    from paramdds.formats.schema import load_schema_str
    from paramdds.formats.spec import load_spec_str

    spec = load_spec_str(
        "p:\n  mode: {type: string, validation: {one_of<>: [[eco, sport]]}}\n"
        "  level: {type: int, validation: {one_of<>: [[1, 2, 3]]}}\n"
        "  tags: {type: string_array, validation: {subset_of<>: [[a, b]]}}\n"
    )
    assert [_choices_of(e.descriptor) for e in spec] == [["eco", "sport"], [1, 2, 3], None]
    props = {
        "mode": {"type": "string", "enum": ["eco", "sport"], "default": "eco"},
        "level": {"type": "integer", "enum": [1, 2, 3], "minimum": 0, "default": 1},
        "gain": {"type": "number", "enum": [0.5, 1], "default": 1},
        "mixed": {"type": "string", "enum": ["a", 1], "default": "a"},
        "tags": {"type": "array", "items": {"type": "string", "enum": ["a", "b"]}, "default": ["a"]},
        "free": {"type": "string", "description": "one of [\"x\"] in prose", "default": "x"},
    }
    node = {"properties": props, "required": ["mode"]}
    doc = {"properties": {"/**": {"properties": {"ros__parameters": node}}}}
    schema = load_schema_str(json.dumps(doc))
    got = {e.name: _choices_of(e.descriptor) for e in schema.entries}
    assert got == {
        "mode": ["eco", "sport"],  # after the note 'required'
        "level": [1, 2, 3],
        "gain": [0.5, 1],
        "mixed": None,  # not all of the parameter's type: a free editor
        "tags": None,  # an array: its items' enum is not a choice of one value
        "free": None,  # a description is not a constraint
    }


def test_choices_need_a_whole_list_of_the_parameters_type() -> None:
    def of(constraints: str, ptype: ParameterType = ParameterType.STRING) -> object:
        return choices({"type": ptype.label, "additional_constraints": constraints, "validators": []}, ptype)

    assert of('one of ["a", "b"]') == ["a", "b"]
    assert of('required; group \'g\': oneOf [{"x": 1}]; one of ["a", "b, c"]') == ["a", "b, c"]
    assert of('one of ["a", "b"…') is None  # cut at the text's limit
    assert of("not one of these") is None and of("") is None and of("one of []") is None
    assert of('none of ["a"]') is None  # a word that merely ends in "one of"
    assert of("one of [true, false]", ParameterType.BOOL) is None  # a bool has its checkbox
    assert of("one of [1, 2.5]", ParameterType.INTEGER) is None


@given(st.floats(min_value=0.0, max_value=5.0))
def test_every_double_in_range_is_accepted(x: float) -> None:
    assert typed_value("speed", x, SPEED).value == x


def test_undeclared_names_are_typed_by_their_json() -> None:
    assert typed_value("new", [1, 2], None).type is ParameterType.INTEGER_ARRAY
    with pytest.raises(TypeMismatchError, match="empty list"):
        typed_value("new", [], None)


@pytest.mark.parametrize(
    ("text", "expected"),
    [("127.0.0.1:8800", ("127.0.0.1", 8800)), ("[::1]:0", ("::1", 0)), ("0.0.0.0:80", ("0.0.0.0", 80))],
)
def test_parse_bind(text: str, expected: tuple[str, int]) -> None:
    assert parse_bind(text) == expected


@pytest.mark.parametrize("text", ["8800", ":8800", "host:x", "host:70000"])
def test_parse_bind_refuses(text: str) -> None:
    with pytest.raises(UsageError):
        parse_bind(text)


def test_writes_on_a_non_loopback_bind_need_a_token() -> None:
    args = argparse.Namespace(token_file=None, read_only=False, domain=1, timeout=5.0)
    assert is_loopback("127.0.0.1") and is_loopback("::1") and not is_loopback("0.0.0.0")
    assert options_from(args, "127.0.0.1").allowed_hosts[:2] == ("localhost", "127.0.0.1")
    with pytest.raises(UsageError, match="--token-file"):
        options_from(args, "0.0.0.0")
    args.read_only = True
    with pytest.raises(UsageError, match="--token-file"):  # there reads need the token too
        options_from(args, "0.0.0.0")


def test_the_host_check_holds_on_every_bind(tmp_path: Path) -> None:
    token = tmp_path / "token"
    token.write_text("a-token-of-enough-length\n")
    args = argparse.Namespace(token_file=str(token), read_only=True, domain=1, timeout=5.0, allow_host=None)
    remote = options_from(args, "10.99.0.1")
    assert remote.allowed_hosts == ("10.99.0.1",) and remote.token_for_reads
    args.allow_host = ["robot.example", "Console.Lan"]
    assert options_from(args, "10.99.0.1").allowed_hosts == ("10.99.0.1", "robot.example", "console.lan")
    wildcard = options_from(args, "0.0.0.0").allowed_hosts
    assert {"localhost", "127.0.0.1", "robot.example"} <= set(wildcard) and "evil.example" not in wildcard
    local = options_from(args, "127.0.0.1")
    assert not local.token_for_reads and "robot.example" in local.allowed_hosts


def _streamed(view: StateView, node: str, events: list[MonitorEvent]) -> list[str]:
    """The messages a console's event stream (subscribed to ``node``) gets for ``events``."""

    async def run() -> list[str]:
        hub = Hub(view, asyncio.get_running_loop())
        sub = hub.subscribe(node)
        for event in events:
            hub.on_event(event)
        await asyncio.sleep(0.2)
        messages = []
        while not sub.queue.empty():
            item = sub.queue.get_nowait()
            assert item is not None
            messages.append(item)
        return messages

    return asyncio.run(run())


def test_a_burst_is_coalesced_into_one_message_per_kind() -> None:
    burst = [
        MonitorEvent(EventKind.MODIFIED, "arm", "gain", ParameterValue(ParameterType.INTEGER, i), None, i + 1)
        for i in range(500)
    ]
    messages = _streamed(StateView(), "arm", burst)
    kinds = [m.split("\n", 1)[0] for m in messages]
    assert kinds == ["event: params", "event: nodes", "event: log"]
    params = messages[0]
    assert params.count('"name":"gain"') == 1 and '"value":499' in params  # last value wins
    assert '"skipped":450' in messages[2]  # the log keeps the newest 50 of a burst


def test_a_missing_web_extra_is_a_clear_usage_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    from paramdds.cli.verbs import web

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "uvicorn" else real(name, *a)
    )
    with pytest.raises(UsageError, match=r"uvicorn not installed.*pip install -e '\.\[web\]'"):
        web.run(argparse.Namespace())


def test_the_view_follows_a_restart_instead_of_keeping_the_highest_revision() -> None:
    """A node's events raise the revision shown within one incarnation; events of another
    incarnation (a restart, counting again) never hold it up."""
    from paramdds.dds.monitor import NodeState

    view = StateView()
    old, new = (
        NodeState("n", online=True, revision=9, incarnation=1),
        NodeState("n", online=True, revision=9, incarnation=2),
    )
    view.note_revision("n", 13, 1)
    assert view._summary(old).revision == 13  # the newest event of this start
    assert view._summary(new).revision == 9  # restarted: its own revision, not 13
    view.note_revision("n", 10, 2)
    assert view._summary(new).revision == 10
    view.note_revision("n", 12, 1)  # a late event of the old start does not count for the new one
    assert view._summary(new).revision == 9


def test_a_status_change_alone_updates_the_node_list_and_the_log() -> None:
    """A ROS 2 mirror shown stale (no parameter changed): the console's node list gets the
    node's new summary and its log a ``status`` line, at once, not at a later refresh."""
    from typing import cast

    from paramdds.core.state_book import StateBook
    from paramdds.dds.monitor import ParameterMonitor

    monitor = StateBook()
    with monitor.update() as change:
        held = change.node("arm/driver")
        held.online, held.origin, held.status = True, "ros2", "stale"

    event = MonitorEvent(EventKind.STATUS, "arm/driver", revision=3, origin="ros2", status="stale")
    nodes, log = _streamed(StateView(cast(ParameterMonitor, monitor)), "", [event])
    assert nodes.startswith("event: nodes") and '"node":"arm/driver"' in nodes and '"status":"stale"' in nodes
    assert log.startswith("event: log") and '"event":"status"' in log and '"status":"stale"' in log


def test_the_sites_lacking_are_listed_once_synced_and_a_change_refreshes_the_page() -> None:
    """Over Zenoh the view lists the sites it lacks once the first sync is done (before it,
    every site would read as lacking); the event stream tells the page to re-read its page
    when they change, at the flush of an event (a site_offline) or at the next check when a
    change came with no event (a refusal), and not when they stay."""
    from typing import cast

    from paramdds.core.state_book import StateBook
    from paramdds.dds.monitor import ParameterMonitor
    from paramdds.web.hub import SITES_CHECK
    from paramdds.zenoh.completeness import SiteLedger

    monitor = StateBook()
    ledger = SiteLedger(["east", "north"])
    ledger.gateways_up(["north"])
    ledger.answered(["north"])
    down: set[str] = set()
    view = StateView()
    view.attach(cast(ParameterMonitor, monitor), lambda: ledger.missing(down=down))
    assert view.follows_sites and view.lacking() == [] and not StateView().follows_sites
    monitor.mark_synced()
    assert [(m["site"], m["status"]) for m in view.lacking()] == [("east", "no answer")]
    refresh = 'event: nodes\ndata: {"refresh":true}\n\n'

    async def run() -> list[list[str]]:
        hub = Hub(view, asyncio.get_running_loop())
        hub.follow_sites()
        sub = hub.subscribe("")
        got: list[list[str]] = []

        async def after(event: MonitorEvent | None, wait: float = 0.2) -> None:
            if event is not None:
                hub.on_event(event)
            await asyncio.sleep(wait)
            got.append([sub.queue.get_nowait() or "" for _ in range(sub.queue.qsize())])

        down.add("north")
        await after(MonitorEvent(EventKind.SITE_OFFLINE, site="north"))
        await after(MonitorEvent(EventKind.SYNCED))  # nothing changed: no refresh
        ledger.refused(["east"])
        ledger.gateways_up(["east"])  # east's gateway is up but refuses this console: no event
        await after(None, SITES_CHECK + 0.3)
        hub.close()
        return got

    offline, same, refused = asyncio.run(run())
    assert refresh in offline and refresh not in same and refused == [refresh]
    shown = [(m["site"], m["status"]) for m in view.lacking()]
    assert shown == [("east", "not granted"), ("north", "no answer")]
