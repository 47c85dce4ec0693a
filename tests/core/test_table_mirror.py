"""ParameterTable.mirror: entries committed as they are, for a table mirroring another node."""

from __future__ import annotations

from paramdds.core.descriptors import IntegerRange, ParameterDescriptor
from paramdds.core.results import ChangeKind, ChangeSet, SetVeto
from paramdds.core.table import ParameterTable
from paramdds.core.values import ParameterType, ParameterValue


def _v(x: object) -> ParameterValue:
    return ParameterValue.from_python(x)


def test_mirror_commits_as_given_in_one_revision_without_callbacks() -> None:
    t = ParameterTable("ns/node")
    t.declare("keep", 1)
    t.declare("gone", "x", ParameterDescriptor("gone", dynamic_typing=True))
    vetoed: list[object] = []
    t.add_on_set_callback(lambda ps: vetoed.append(ps) or SetVeto(False, "no"))
    seen: list[ChangeSet] = []
    t.add_change_listener(seen.append)
    before = t.revision
    # out of its own range: the mirrored node accepted it, the mirror does not judge
    wide = ParameterDescriptor("count", ParameterType.INTEGER, integer_range=IntegerRange(0, 10, 2))
    change = t.mirror({"count": (_v(13), wide), "gone": None, "keep": (_v(1), t.describe_one("keep"))})
    assert change is not None and change.revision == before + 1 == t.revision
    assert {(c.kind, c.name) for c in change.changes} == {
        (ChangeKind.NEW, "count"),
        (ChangeKind.DELETED, "gone"),
    }
    assert seen == [change] and vetoed == []
    assert t.get("count") == _v(13) and t.describe_one("count") == wide and not t.has("gone")


def test_mirror_of_what_the_table_holds_changes_nothing() -> None:
    t = ParameterTable("n")
    t.declare("a", 1.5)
    assert t.mirror({"a": (_v(1.5), t.describe_one("a"))}) is None
    assert t.revision == 1
