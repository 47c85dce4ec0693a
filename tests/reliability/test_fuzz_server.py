"""Hypothesis fuzz of the server's request handling, on real Cyclone, against a model.

Random set requests (plain and atomic, any node id, any name, values of every
type including NaN, ±inf, int64 limits, long and mixed arrays) go through a raw
cyclonedds writer straight to an in-process :class:`ParameterServer`, skipping
every client-side check. The same requests are applied directly to a fresh core
:class:`ParameterTable` (the model: what the core's rules say). After each case
the server still answers, each reply agrees with the model's results, and the
served table equals the model's (``same_as``, so NaN equals NaN).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import IntegerRange, ParameterDescriptor
from paramdds.core.limits import MAX_PARAMETERS_PER_REQUEST
from paramdds.core.results import SetResult
from paramdds.core.table import ParameterTable
from paramdds.dds.server import ParameterServer
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.convert import parameter_from_wire
from paramdds.errors import ParamddsError

from .conftest import DDS
from .rawwire import RawPeer

INT64 = (-(2**63), 2**63 - 1)
_nodes = itertools.count(1)
_ids = itertools.count(1)


def _make_table(node: str, *, open_: bool) -> ParameterTable:
    table = ParameterTable(node, allow_undeclared=open_)
    table.declare("b", True)
    table.declare("i", 3, ParameterDescriptor("i", integer_range=IntegerRange(-100, 100, 1)))
    table.declare("d", 1.5)
    table.declare("s", "text")
    table.declare("ro", 7, ParameterDescriptor("ro", read_only=True))
    table.declare("dyn", "x", ParameterDescriptor("dyn", dynamic_typing=True))
    table.declare("arr.ints", [1, 2, 3])
    table.declare("arr.strs", ["a"])
    return table


# -- strategies --------------------------------------------------------------------------------

odd_text = st.one_of(
    st.text(max_size=20),
    st.text(alphabet=st.characters(codec="utf-8"), max_size=40),
    st.sampled_from(["", ".", "..", ".a", "a.", "a..b", "a.b.", "\x00", "\n", "\x7f", "ü.ß", "日本.語"]),
    st.builds(lambda n, c: c * n, st.integers(250, 10_000), st.sampled_from(["a", "é", "\x01"])),
)
names = st.one_of(
    st.sampled_from(["b", "i", "d", "s", "ro", "dyn", "arr.ints", "arr.strs", "new.x"]), odd_text
)
ints = st.one_of(st.sampled_from([*INT64, 0, -1, 100, 101, -100, -101]), st.integers(*INT64))
floats = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, -0.0, 5e-324, 1.7976931348623157e308]), st.floats()
)


def _long(element: Any) -> Any:
    """Arrays: short random ones, or long ones built cheaply (up to past the 4 MiB value limit)."""
    return st.one_of(
        st.lists(element, max_size=8),
        st.builds(lambda n, x: [x] * n, st.sampled_from([1000, 100_000, 600_000]), element),
    )


@st.composite
def wire_values(draw: Any) -> wire.ParameterValue:
    kind = draw(st.integers(0, 9))
    v = wire.ParameterValue(type=kind)
    if kind == 1:
        v.bool_value = draw(st.booleans())
    elif kind == 2:
        v.integer_value = draw(ints)
    elif kind == 3:
        v.double_value = draw(floats)
    elif kind == 4:
        v.string_value = draw(odd_text)
    elif kind == 5:
        v.byte_array_value = draw(_long(st.integers(0, 255)))
    elif kind == 6:
        v.bool_array_value = draw(_long(st.booleans()))
    elif kind == 7:
        v.integer_array_value = draw(_long(ints))
    elif kind == 8:
        v.double_array_value = draw(_long(floats))
    elif kind == 9:
        v.string_array_value = draw(st.lists(odd_text, max_size=5))
    if draw(st.booleans()):  # junk in a member the type byte does not name
        v.integer_value, v.string_value = (v.integer_value or 1), (v.string_value or "junk")
    return v


@st.composite
def requests(draw: Any) -> tuple[str, wire.SetParametersRequest]:
    target = draw(st.one_of(st.sampled_from(["strict", "open", "/strict", "absent"]), st.text(max_size=300)))
    params = draw(st.lists(st.builds(wire.Parameter, names, wire_values()), max_size=6))
    expected = draw(st.sampled_from([-1, -1, -1, -7, 0, 2**63 - 1]))
    return target, wire.SetParametersRequest(
        node_id=target,
        client_id=42,
        request_id=next(_ids),
        atomic=draw(st.booleans()),
        expected_revision=expected,
        parameters=params,
    )


# -- the model ---------------------------------------------------------------------------------


def model_apply(table: ParameterTable, request: wire.SetParametersRequest) -> list[tuple[bool, str]]:
    """The core's rules for one request: (successful, code) per parameter."""
    if len(request.parameters) > MAX_PARAMETERS_PER_REQUEST:
        return []
    converted: list[Any] = []
    for p in request.parameters:
        try:
            converted.append(parameter_from_wire(p))
        except ParamddsError as exc:
            converted.append(SetResult(p.name, False, exc.message, exc.code))
    expected = None if request.expected_revision < 0 else request.expected_revision
    good = [p for p in converted if not isinstance(p, SetResult)]
    if request.atomic and len(good) != len(converted):
        return [(False, "x") for _ in converted]
    outcome = (table.set_atomically if request.atomic else table.set)(good, expected_revision=expected)
    merged: Iterator[SetResult] = iter(outcome.results)
    results = [p if isinstance(p, SetResult) else next(merged) for p in converted]
    return [(r.successful, r.code.value if r.code else "") for r in results]


def same_tables(a: ParameterTable, b: ParameterTable) -> bool:
    sa, sb = a.snapshot(), b.snapshot()
    return (
        a.revision == b.revision
        and [n for n, _, _ in sa] == [n for n, _, _ in sb]
        and all(va.same_as(vb) and da == db for (_, va, da), (_, vb, db) in zip(sa, sb, strict=True))
    )


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_fuzzed_set_requests_keep_server_alive_and_equal_to_the_model(domain_id: int, dds: DDS) -> None:
    server = ParameterServer(dds.participant(domain_id))
    dds.own(server.start())
    peer = RawPeer(dds.participant(domain_id))
    hosted: dict[str, ParameterTable] = {}

    @settings(
        max_examples=150,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
        derandomize=False,
    )
    @given(st.lists(requests(), min_size=1, max_size=4))
    def case(batch: list[tuple[str, wire.SetParametersRequest]]) -> None:
        # a fresh pair of nodes for every example (the server keeps serving throughout)
        for node in list(hosted):
            server.remove_node(hosted.pop(node).node_id)
        n = next(_nodes)
        tables = {
            "strict": _make_table(f"strict{n}", open_=False),
            "open": _make_table(f"open{n}", open_=True),
        }
        models = {
            "strict": _make_table(f"strict{n}", open_=False),
            "open": _make_table(f"open{n}", open_=True),
        }
        for key, table in tables.items():
            server.add_node(table)
            hosted[key] = table
        for target, request in batch:
            key = target.lstrip("/")
            if key in tables:
                request.node_id = (
                    tables[key].node_id if not target.startswith("/") else "/" + tables[key].node_id
                )
            try:
                peer.send(request)
            except Exception:  # a sample Cyclone cannot encode never leaves this process
                continue
            if key not in tables:
                continue  # not hosted: ignored (checked below: the tables are untouched)
            reply = peer.replies(request, timeout=20)
            assert reply, f"no reply to {request.request_id}"
            expected = model_apply(models[key], request)
            if not expected and request.parameters:
                assert reply[0].code == "TOO_LARGE"
                continue
            got = [(r.successful, r.code) for r in reply[0].results]
            if request.atomic and any(not ok for ok, _ in expected):
                assert not any(ok for ok, _ in got), (got, expected)
            else:
                assert got == expected, (got, expected)
            assert reply[0].revision == models[key].revision
        for key in tables:
            assert same_tables(tables[key], models[key]), key
        # the server still answers a plain get on each node
        probe = wire.GetParametersRequest(
            node_id=tables["strict"].node_id, client_id=42, request_id=next(_ids)
        )
        probe.names = ["i"]
        assert peer.call(probe, timeout=10).results[0].code == ""

    case()
