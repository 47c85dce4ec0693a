"""The recording format, pure: messages fit their schemas, values round-trip, a torn file is a prefix."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.results import LastChange
from paramdds.core.values import NOT_SET, ParameterType, ParameterValue
from paramdds.errors import FileFormatError
from paramdds.formats import recording as fmt
from paramdds.record.mcapfile import McapFile, Split, parse_split, part_path

from ..core.test_jsonform import values

T = ParameterType
PV = ParameterValue
NOW = 1_795_000_000_123_456_789
set_values = values().filter(lambda v: v.type is not T.NOT_SET)


def _valid(channel: fmt.Channel, body: dict[str, object]) -> None:
    jsonschema.validate(json.loads(fmt.encode(body)), dict(channel.schema))


@given(old=st.none() | set_values, new=st.none() | set_values)
def test_a_change_matches_its_schema_and_reads_back(old: PV | None, new: PV | None) -> None:
    body = fmt.change_message(
        "robot1", "a.b", old, new, who="alice", verified=False, via="cli", revision=7, time_ns=NOW
    )
    _valid(fmt.CHANGES, body)
    assert body["kind"] == ("deleted" if new is None else "added" if old is None else "modified")
    record = fmt._change(1, NOW, fmt.decode(fmt.encode(body)))
    for got, want in ((record.old, old), (record.new, new)):
        assert (got is None) == (want is None)
        if got is not None and want is not None:
            assert got.same_as(want), (got, want)
    assert (record.who, record.via, record.revision, record.time_ns) == ("alice", "cli", 7, NOW)


@pytest.mark.parametrize(
    ("value", "plotted"),
    [
        (PV.of(T.DOUBLE, 2.5), 2.5),
        (PV.of(T.INTEGER, -3), -3),
        (PV.of(T.BOOL, True), 1),
        (PV.of(T.BOOL, False), 0),
        (PV.of(T.DOUBLE, math.nan), None),
        (PV.of(T.DOUBLE, math.inf), None),
        (PV.of(T.STRING, "2"), None),
        (PV.of(T.DOUBLE_ARRAY, [1.0]), None),
        (None, None),
    ],
)
def test_the_plot_field_is_a_number_or_null(value: PV | None, plotted: float | None) -> None:
    assert fmt.plot_value(value) == plotted


def test_snapshot_presence_and_gap_messages_match_their_schemas() -> None:
    d = ParameterDescriptor("a", T.DOUBLE, description="speed")
    last = LastChange("alice", True, "cli", NOW, 3)
    params = [
        ("a", PV.of(T.DOUBLE, 1.0), d, last),
        ("b", PV.of(T.STRING, "x"), ParameterDescriptor("b", T.STRING), None),
    ]
    snap = fmt.snapshot_message(
        "robot1", online=True, incarnation=2**63 + 5, revision=3, time_ns=NOW, parameters=params
    )
    _valid(fmt.SNAPSHOT, snap)
    got = fmt._snapshot(NOW, fmt.decode(fmt.encode(snap)))
    assert got.values == {"a": PV.of(T.DOUBLE, 1.0), "b": PV.of(T.STRING, "x")}
    assert got.descriptors["a"] == d and got.revision == 3
    _valid(
        fmt.PRESENCE,
        fmt.presence_message("r", "offline", online=False, incarnation=1, revision=3, time_ns=NOW),
    )
    _valid(fmt.GAPS, fmt.gap_message("r", 3, 9, "the node keeps no history", NOW))
    # not_set is no parameter: left out of a snapshot
    unset = [("n", NOT_SET, ParameterDescriptor("n"), None)]
    empty = fmt.snapshot_message("r", online=False, incarnation=0, revision=0, time_ns=NOW, parameters=unset)
    assert empty["parameters"] == []


def _write(path: Path, flushes: int) -> list[float]:
    """A recording of one snapshot and ``flushes`` batches of 3 changes, each batch flushed."""
    f = McapFile(str(path))
    d = ParameterDescriptor("v", T.DOUBLE)
    start = [("v", PV.of(T.DOUBLE, 0.0), d, None)]
    f.write(
        fmt.SNAPSHOT,
        fmt.snapshot_message("n", online=True, incarnation=1, revision=1, time_ns=NOW, parameters=start),
        NOW,
    )
    f.flush()
    written = []
    for batch in range(flushes):
        for i in range(3):
            v = float(batch * 3 + i + 1)
            f.write(fmt.CHANGES, fmt.change_message(
                "n", "v", PV.of(T.DOUBLE, v - 1), PV.of(T.DOUBLE, v), who="w", verified=False, via="cli",
                revision=int(v) + 1, time_ns=NOW + int(v),
            ), NOW + int(v))  # fmt: skip
            written.append(v)
        f.flush()
    f.finish()
    return written


def test_a_finished_recording_reads_whole_and_its_states_rebuild(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    written = _write(path, 3)
    rec = fmt.read_recording(str(path))
    assert rec.torn is None and rec.nodes == ["n"]
    assert [r.new.value for r in rec.changes if r.new is not None] == written
    assert rec.state_at("n", revision=4) == (
        {"v": PV.of(T.DOUBLE, 3.0)},
        {"v": ParameterDescriptor("v", T.DOUBLE)},
    )
    assert rec.state_at("n", time_ns=NOW + 5)[0] == {"v": PV.of(T.DOUBLE, 5.0)}  # type: ignore[index]
    assert rec.state_at("n", time_ns=NOW - 1) is None  # before the recording
    assert rec.state_at("ghost") is None


def test_a_torn_recording_reads_as_a_prefix_whatever_the_cut(tmp_path: Path) -> None:
    path = tmp_path / "r.mcap"
    written = _write(path, 4)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    prefixes = set()
    for end in range(0, len(data), 7):
        cut.write_bytes(data[:end])
        rec = fmt.read_recording(str(cut))
        got = [r.new.value for r in rec.changes if r.new is not None]
        assert got == written[: len(got)]
        assert len(got) % 3 == 0  # a flushed batch is there whole, or not at all
        prefixes.add(len(got))
        if rec.torn is None:
            assert got == written
    assert prefixes == {0, 3, 6, 9, 12}


def test_a_file_that_is_no_recording_is_a_format_error(tmp_path: Path) -> None:
    other = tmp_path / "x.yaml"
    other.write_text("robot1:\n  ros__parameters: {}\n")
    with pytest.raises(FileFormatError, match="not an MCAP file"):
        fmt.read_recording(str(other))
    with pytest.raises(FileFormatError, match="cannot read"):
        fmt.read_recording(str(tmp_path / "missing.mcap"))


@pytest.mark.parametrize(
    ("text", "split"),
    [("100MB", Split(size=100 * 10**6)), ("1GiB", Split(size=2**30)), ("500kb", Split(size=500_000)),
     ("30s", Split(seconds=30.0)), ("10m", Split(seconds=600.0)), ("1h", Split(seconds=3600.0))],
)  # fmt: skip
def test_split_sizes_and_durations(text: str, split: Split) -> None:
    assert parse_split(text) == split


@pytest.mark.parametrize("text", ["10", "10 parsecs", "1KB", "0.5s", "", "MB"])
def test_a_split_that_is_neither_is_refused(text: str) -> None:
    with pytest.raises(ValueError):
        parse_split(text)


def test_the_parts_of_a_split_recording_are_numbered() -> None:
    assert part_path("/x/rec.mcap", 1) == "/x/rec-0001.mcap"
    assert part_path("rec", 12) == "rec-0012.mcap"


@settings(max_examples=25, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(value=set_values)
def test_any_value_survives_a_file(tmp_path: Path, value: PV) -> None:
    path = tmp_path / "one.mcap"
    f = McapFile(str(path))
    body = fmt.change_message(
        "n", "p", None, value, who="w", verified=True, via="api", revision=2, time_ns=NOW
    )
    f.write(fmt.CHANGES, body, NOW)
    f.finish()
    (record,) = fmt.read_recording(str(path)).changes
    assert record.new is not None and record.new.same_as(value) and record.verified


def test_a_file_is_full_at_its_split_size(tmp_path: Path) -> None:
    f = McapFile(str(tmp_path / "s.mcap"))
    split = Split(size=64 * 1024)
    body = fmt.gap_message("n", 1, 3, "x" * 200, NOW)
    while not f.full(split):
        for _ in range(50):
            f.write(fmt.GAPS, body, NOW)
        f.flush()  # the size counts what is written: chunks close on flush
    assert f.size() >= 64 * 1024 and not f.full(Split())
    f.finish()
    assert len(fmt.read_recording(str(tmp_path / "s.mcap")).gaps) > 50
