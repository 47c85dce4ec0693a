"""The past's JSON over Zenoh without Zenoh or DDS: last changes, history queries and pages."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.history import PAGE_SIZE, HistoryPage, HistoryQuery, HistoryRecord, Outcome
from paramdds.core.results import LastChange
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import FileFormatError, ParamddsError
from paramdds.zenoh import codec, history


def _record(seq: int, *, new: ParameterValue | None, applied: bool = True) -> HistoryRecord:
    return HistoryRecord(
        seq, "s1/robot1", "robot.max_velocity", 7, 1_764_380_000_123_456_789, "operator", False, "zenoh",
        ParameterValue.of(ParameterType.DOUBLE, 1.5), new, applied,
        "" if applied else "OUT_OF_RANGE", "" if applied else "9.0 is above 3.0",
    )  # fmt: skip


def test_a_last_change_reads_as_describe_prints_it_to_the_microsecond() -> None:
    lc = LastChange("operator", False, "zenoh", 1_764_380_000_123_456_000, 12)
    obj = codec.last_change_out(lc)
    assert obj == {
        "who": "operator", "verified": False, "via": "zenoh", "time": "2025-11-29T01:33:20.123456Z",
        "revision": 12,
    }  # fmt: skip
    assert codec.last_change_in(json.loads(json.dumps(obj))) == lc
    finer = LastChange("operator", False, "zenoh", 1_764_380_000_123_456_789, 12)
    back = codec.last_change_in(codec.last_change_out(finer))
    assert back is not None and abs(back.time_ns - finer.time_ns) <= 1_000
    # a writer that sends the exact time beside it (another language) is read exactly
    assert codec.last_change_in({**obj, "time_ns": finer.time_ns}) == finer
    assert codec.last_change_out(None) is None and codec.last_change_in(None) is None


BAD_TIME = {**LastChange("a", True, "cli", 0, 1).to_json(), "time": "x"}


@pytest.mark.parametrize("bad", [{"who": "x"}, "text", BAD_TIME])
def test_a_malformed_last_change_is_a_clear_error(bad: object) -> None:
    with pytest.raises(FileFormatError, match="a malformed last change"):
        codec.last_change_in(bad)


@given(
    names=st.lists(st.text(min_size=1, max_size=8), max_size=3),
    since=st.none() | st.integers(0, 2**40),
    t0=st.none() | st.integers(0, 2**62),
    outcome=st.sampled_from(list(Outcome)),
    after=st.integers(0, 2**40),
    limit=st.integers(0, 500),
)
def test_every_history_query_round_trips(
    names: list[str], since: int | None, t0: int | None, outcome: Outcome, after: int, limit: int
) -> None:
    q = HistoryQuery(tuple(names), since, t0, t0, "op*", outcome, after, limit)
    obj = json.loads(json.dumps({**history.query_out(q), "timeout": 2.0}))
    assert history.query_in(obj) == q


@pytest.mark.parametrize(
    "bad, says",
    [
        ({"names": "robot.mode"}, "'names' must be a list"),
        ({"outcome": "maybe"}, "'outcome' must be one of all, applied, refused"),
        ({"since_revision": "3"}, "'since_revision' must be an integer or null"),
        ({"after_seq": True}, "'after_seq' must be an integer or null"),
    ],
)
def test_a_bad_history_request_says_what_is_wrong(bad: dict[str, object], says: str) -> None:
    with pytest.raises(ParamddsError, match=says):
        history.query_in(bad)


def test_a_page_asked_over_zenoh_is_at_most_the_nodes_page_size() -> None:
    assert history.query_in({"limit": 10**9}).limit == PAGE_SIZE
    assert history.query_in({"limit": -5}).limit == 0  # 0: the node's page size


def test_a_page_round_trips_with_its_flags_and_records_keep_their_types() -> None:
    records = (
        _record(1, new=ParameterValue.of(ParameterType.DOUBLE, 2.0)),
        _record(2, new=None),  # a delete
        _record(3, new=ParameterValue.of(ParameterType.DOUBLE, 9.0), applied=False),
    )
    payload = history.history_reply("s1/robot1", HistoryPage(records, more=True, compacted=True), True)
    obj = json.loads(payload)
    assert [r["outcome"] for r in obj["records"]] == ["applied", "applied", "refused"]
    assert obj["records"][0]["old"] == {"type": "double", "value": 1.5}
    assert obj["records"][1]["new"] is None
    page, kept = history.page_of(obj)
    assert kept and page == HistoryPage(records, more=True, compacted=True)


def test_a_node_without_history_says_so_and_a_malformed_page_is_a_clear_error() -> None:
    page, kept = history.page_of(json.loads(history.history_reply("s1/n", HistoryPage(()), False)))
    assert not kept and page.records == ()
    with pytest.raises(FileFormatError, match="a malformed history reply"):
        history.page_of({"ok": True, "records": [{"seq": 1}]})
    with pytest.raises(FileFormatError, match="a malformed history reply"):
        bad_old = {**history.record_out(_record(1, new=None)), "old": {"v": 1}}
        history.page_of({"ok": True, "records": [bad_old]})


def test_a_node_state_carries_each_parameters_last_change_and_an_older_one_none() -> None:
    v = ParameterValue.of(ParameterType.DOUBLE, 2.0)
    d = ParameterDescriptor("robot.max_velocity", ParameterType.DOUBLE)
    lc = LastChange("operator", False, "zenoh", 1_764_380_000_123_456_000, 3)
    params = {"robot.max_velocity": (v, d), "robot.mode": (ParameterValue.of(ParameterType.STRING, "a"), d)}
    msg = codec.NodeStateMsg("s1", "robot1", "gw", 1, True, parameters=params)
    msg.last_changes = {"robot.max_velocity": lc}
    payload = msg.encode()
    obj = json.loads(payload)
    assert obj["parameters"]["robot.max_velocity"]["last_change"]["who"] == "operator"
    assert obj["parameters"]["robot.mode"]["last_change"] is None
    assert codec.NodeStateMsg.decode(payload).last_changes == {"robot.max_velocity": lc}
    for entry in obj["parameters"].values():  # what an older gateway sends
        del entry["last_change"]
    assert codec.NodeStateMsg.decode(json.dumps(obj).encode()).last_changes == {}
