"""The --persist journal's lines, without DDS: round trips, torn and damaged lines, epochs.

* Any change set (every value type with NaN and infinities, any descriptor, deletions)
  survives encode_record → read_journal → the store's reading, value and descriptor.
* A torn last line (a crash during an append) is dropped; a bad line before the last
  is damage and refuses the load; a journal whose epoch is not the snapshot's is
  ignored (a crash between a compaction's two steps).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.jsonform import descriptor_of_row as _descriptor_from_json
from paramdds.core.jsonform import value_of_row as _value_from_json
from paramdds.core.results import ChangeKind, ChangeSet, ParameterChange
from paramdds.core.table import ParameterTable
from paramdds.core.values import NOT_SET, Parameter, ParameterValue
from paramdds.formats.files import dump_text, parse_ros_text
from paramdds.persist import (
    PREALLOCATE,
    PersistError,
    PersistStore,
    encode_record,
    read_journal,
)

from .core.test_yaml_dump import _NAMES, _VALUES, _descriptors, _floats


def _store(path: Path) -> PersistStore:
    return PersistStore(path, dumper=lambda s: dump_text(s, with_descriptors=True), parser=parse_ros_text)


@st.composite
def _changes(draw: st.DrawFn) -> list[ParameterChange]:
    out = []
    for name in draw(st.lists(_NAMES, min_size=1, max_size=4, unique=True)):
        if draw(st.booleans()):
            value = draw(_VALUES)
            desc = draw(_descriptors(name, value)) or ParameterDescriptor(name, value.type)
            out.append(ParameterChange(ChangeKind.CHANGED, name, value, desc))
        else:
            out.append(ParameterChange(ChangeKind.DELETED, name, NOT_SET, ParameterDescriptor(name)))
    return out


@settings(max_examples=150, deadline=None)
@given(_changes())
def test_a_change_set_round_trips_through_a_journal_line(changes: list[ParameterChange]) -> None:
    line = encode_record(ChangeSet("ns/n", 7, tuple(changes)))
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    epoch, nodes = read_journal(b"# paramdds journal epoch=e1 pid=1 host=h\n" + line, "j")
    assert epoch == "e1"
    entries = nodes["ns/n"]
    assert list(entries) == [c.name for c in changes]
    for c in changes:
        entry = entries[c.name]
        if c.kind is ChangeKind.DELETED:
            assert entry == [c.name]
            continue
        value = _value_from_json(entry[1:3])
        desc = _descriptor_from_json(c.name, entry[3])
        assert value.same_as(c.value)
        if not any(math.isnan(x) for x in _floats(c.descriptor)):
            assert desc == c.descriptor


def _journal(*lines: bytes, epoch: str = "e1") -> bytes:
    return b"".join([f"# paramdds journal epoch={epoch} pid=1 host=h\n".encode(), *lines])


def _set(rev: int, name: str, value: object) -> bytes:
    v = ParameterValue.from_python(value)
    return encode_record(
        ChangeSet(
            "n", rev, (ParameterChange(ChangeKind.CHANGED, name, v, ParameterDescriptor(name, v.type)),)
        )
    )


def test_a_torn_last_line_is_dropped_and_a_damaged_middle_line_refused() -> None:
    a, b = _set(2, "x", 1), _set(3, "x", 2)
    _, nodes = read_journal(_journal(a, b), "j")  # positive control: both lines apply
    assert nodes["n"]["x"][2] == 2
    _, nodes = read_journal(_journal(a, b[:-5]), "j")  # torn: the crash came during the append
    assert nodes["n"]["x"][2] == 1
    damaged = a[:12] + (b"X" if a[12:13] != b"X" else b"Y") + a[13:]
    with pytest.raises(PersistError, match="checksum"):
        read_journal(_journal(damaged, b), "j")


def test_a_journal_of_another_epoch_is_ignored(tmp_path: Path) -> None:
    state = tmp_path / "s.yaml"
    table = ParameterTable("n")
    table.declare("x", 0)
    store = _store(state)
    store.attach({"n": table})
    store.close()
    epoch = state.read_text().split("# paramdds epoch ")[1].split()[0]
    journal = Path(f"{state}.journal")
    journal.write_bytes(_journal(_set(2, "x", 5), epoch=epoch))
    assert [v.value for n, v, _ in _store(state).read("n") if n == "x"] == [5]  # positive control
    journal.write_bytes(_journal(_set(2, "x", 5), epoch="older"))
    assert [v.value for n, v, _ in _store(state).read("n") if n == "x"] == [0]


def test_the_preallocated_zeros_are_not_records() -> None:
    # the journal grows in zero-filled steps: a reader stops at the first NUL byte
    a, b = _set(2, "x", 1), _set(3, "x", 2)
    zeros = b"\0" * 4096
    _, nodes = read_journal(_journal(a, b) + zeros, "j")  # a clean end: both apply
    assert nodes["n"]["x"][2] == 2
    _, nodes = read_journal(_journal(a, b[:-5]) + zeros, "j")  # torn before the zeros: dropped
    assert nodes["n"]["x"][2] == 1
    _, nodes = read_journal(_journal(a, b[:20] + b"\0" * 10 + b[30:]) + zeros, "j")  # a hole in the tail
    assert nodes["n"]["x"][2] == 1


def test_a_store_preallocates_and_reloads_what_it_appended(tmp_path: Path) -> None:
    table = ParameterTable("n")
    table.declare("x", 0)
    changes: list[ChangeSet] = []
    table.add_change_listener(changes.append)
    store = _store(tmp_path / "s.yaml")
    store.attach({"n": table})
    for v in range(1, 6):
        table.set([Parameter("x", ParameterValue.from_python(v))])
        store.record(table, changes[-1:])
    store.close()
    raw = Path(f"{tmp_path / 's.yaml'}.journal").read_bytes()
    assert len(raw) >= PREALLOCATE and raw.endswith(b"\0")  # zeros ahead of the appends
    reread = _store(tmp_path / "s.yaml")
    assert {name: value.value for name, value, _ in reread.read("n")} == {"x": 5}
