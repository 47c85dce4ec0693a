"""The mirror's two kinds of hosted table, without a ROS 2 graph: a link that answers in-process.

:class:`MirrorTable` holds a plain ParameterTable and forwards sets to its link (the ROS 2
node's services); :class:`UnreachableTable` holds nothing and refuses every request. Only
what the node answers is committed, as it answers it, in one revision per set, event or read.
"""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.limits import MAX_PARAMETERS_PER_REQUEST
from paramdds.core.results import ChangeKind, ChangeSet, SetResult
from paramdds.core.values import NOT_SET, Parameter, ParameterType, ParameterValue
from paramdds.errors import ErrorCode, InvalidValueError, ParamddsError
from paramdds.ros2.mirror import CAS_REFUSED, MirrorTable, UnreachableTable

from .conftest import require_ros2


def _v(x: object) -> ParameterValue:
    return ParameterValue.from_python(x)


class _Node:
    """A ROS 2 node's set service, in-process: refuses the names in ``refuse``, records what it got."""

    fqn = "/arm/driver"

    def __init__(self, refuse: Sequence[str] = ()) -> None:
        self.refuse = set(refuse)
        self.calls: list[tuple[list[Parameter], bool]] = []

    def set(self, params: Sequence[Parameter], atomic: bool, deadline: int = 0) -> list[SetResult]:
        self.calls.append((list(params), atomic))
        if atomic and self.refuse & {p.name for p in params}:
            return [SetResult(p.name, False, "refused by the node", ErrorCode.INVALID_VALUE) for p in params]
        return [
            SetResult(p.name, False, "refused by the node", ErrorCode.INVALID_VALUE)
            if p.name in self.refuse
            else SetResult(p.name, True)
            for p in params
        ]


def _gain() -> ParameterDescriptor:
    return ParameterDescriptor(
        "gain", ParameterType.DOUBLE, floating_point_range=FloatingPointRange(0.0, 1.0, 0.0)
    )


def _mirrored(node: _Node) -> MirrorTable:
    table = MirrorTable("arm/driver", node)  # type: ignore[arg-type]
    table.resync(
        {
            "gain": (_v(0.5), _gain()),
            "mode": (_v("auto"), ParameterDescriptor("mode", ParameterType.STRING, dynamic_typing=True)),
        }
    )
    return table


def test_a_resync_holds_exactly_what_the_node_has_in_one_revision() -> None:
    table = _mirrored(_Node())
    seen: list[ChangeSet] = []
    table.add_change_listener(seen.append)
    rate = ParameterDescriptor("rate", ParameterType.INTEGER)
    assert (table.revision, table.names(), len(table)) == (1, ["gain", "mode"], 2)
    # out of its own range: the node holds it, the mirror does not judge
    table.resync({"gain": (_v(7.0), _gain()), "rate": (_v(10), rate)})
    assert table.revision == 2 and [c.revision for c in seen] == [2]
    assert {(c.kind, c.name) for c in seen[0].changes} == {
        (ChangeKind.CHANGED, "gain"),
        (ChangeKind.NEW, "rate"),
        (ChangeKind.DELETED, "mode"),
    }
    assert [(n, v) for n, v, _ in table.snapshot()] == [("gain", _v(7.0)), ("rate", _v(10))]
    table.resync({"gain": (_v(7.0), _gain()), "rate": (_v(10), rate)})
    assert table.revision == 2 and len(seen) == 1  # the same again: nothing changes


def test_a_set_commits_what_the_node_accepted_in_one_revision() -> None:
    node = _Node(refuse=["mode"])
    table = _mirrored(node)
    seen: list[ChangeSet] = []
    table.add_change_listener(seen.append)
    request = [Parameter("gain", _v(1)), Parameter("mode", _v("manual")), Parameter("new", _v(True))]
    outcome = table.set(request)
    # an integer for a double is typed as a double before it is forwarded (ROS 2 refuses it)
    assert node.calls == [
        ([Parameter("gain", _v(1.0)), Parameter("mode", _v("manual")), Parameter("new", _v(True))], False)
    ]
    assert [r.successful for r in outcome.results] == [True, False, True]
    assert outcome.revision == table.revision == 2 and seen == [outcome.change]
    values = {r.name: r.value for r in table.get_many(["gain", "mode", "new"], with_descriptors=True)}
    assert values == {"gain": _v(1.0), "mode": _v("auto"), "new": _v(True)}
    new = table.get_many(["new"], with_descriptors=True)[0].descriptor
    assert new is not None and new.dynamic_typing and new.type is ParameterType.BOOL


def test_a_deletion_the_node_accepted_removes_the_parameter() -> None:
    table = _mirrored(_Node())
    outcome = table.set([Parameter("mode", NOT_SET)])
    assert outcome.results[0].successful and not table.has("mode") and table.revision == 2


def test_a_set_the_node_refuses_whole_changes_nothing() -> None:
    node = _Node(refuse=["mode"])
    table = _mirrored(node)
    outcome = table.set_atomically([Parameter("gain", _v(0.2)), Parameter("mode", _v("x"))])
    assert node.calls[-1][1] is True
    assert not any(r.successful for r in outcome.results)
    assert outcome.change is None and outcome.revision == table.revision == 1


def test_an_invalid_name_fails_an_atomic_set_before_it_is_forwarded() -> None:
    node = _Node()
    table = _mirrored(node)
    outcome = table.set_atomically([Parameter("gain", _v(0.2)), Parameter("bad..name", _v(1))])
    assert node.calls == []
    assert [(r.name, r.code) for r in outcome.results] == [
        ("gain", ErrorCode.INVALID_VALUE),
        ("bad..name", ErrorCode.INVALID_NAME),
    ]
    assert outcome.results[0].reason == "not applied: the atomic set failed on 'bad..name'"


def test_whole_request_refusals_are_the_tables() -> None:
    node = _Node()
    table = _mirrored(node)
    many = [Parameter(f"p{i}", _v(i)) for i in range(MAX_PARAMETERS_PER_REQUEST + 1)]
    outcome = table.set(many)
    assert {r.code for r in outcome.results} == {ErrorCode.TOO_LARGE} and len(outcome.results) == len(many)
    assert all(r.reason.startswith("not applied: ") for r in outcome.results)
    with pytest.raises(ParamddsError) as cas:
        table.set([Parameter("gain", _v(0.1))], expected_revision=1)
    assert (cas.value.code, cas.value.message) == (ErrorCode.INVALID_VALUE, CAS_REFUSED)
    with pytest.raises(InvalidValueError, match="a set takes a list of Parameter"):
        table.set("gain")  # type: ignore[arg-type]
    assert node.calls == [] and table.revision == 1


def test_an_event_commits_in_one_revision_and_names_what_needs_a_descriptor() -> None:
    require_ros2()
    from paramdds.ros2.messages import parameter_to_ros

    table = _mirrored(_Node())
    new, changed = [parameter_to_ros("count", _v(3))], [parameter_to_ros("mode", _v(2))]
    fresh = table.apply_event(new, changed, [parameter_to_ros("gain", _v(0.5))])
    assert fresh == ["count"] and table.revision == 2
    assert table.names() == ["count", "mode"]
    described = {n: d for n, _, d in table.snapshot()}
    assert described["mode"].type is ParameterType.INTEGER  # dynamically typed: it follows the value
    assert described["count"] == ParameterDescriptor("count", ParameterType.INTEGER)
    read = ParameterDescriptor("count", ParameterType.INTEGER, description="from the node")
    change = table.mirror({"count": (_v(3), read)})
    assert change is not None and table.snapshot()[0][2] == read and table.revision == 3


def test_an_unreachable_node_holds_nothing_and_refuses_every_request() -> None:
    table = UnreachableTable("quiet/node", "/quiet/node")
    assert (table.node_id, table.revision, len(table), table.names(), table.snapshot()) == (
        "quiet/node",
        0,
        0,
        [],
        [],
    )
    assert not table.forwards_writes and not table.has("x")
    for call in (
        lambda: table.get_many(["x"]),
        lambda: table.list(),
        lambda: table.set([Parameter("x", _v(1))]),
        lambda: table.set_atomically([Parameter("x", _v(1))]),
    ):
        with pytest.raises(ParamddsError, match="parameter services do not answer") as refused:
            call()
        assert refused.value.code is ErrorCode.UNAVAILABLE
    with table.try_locked() as free:
        assert free


class _Echoing(_Node):
    """A node that sends its parameter event before it answers (what rclpy may do)."""

    def __init__(self) -> None:
        super().__init__()
        self.table: MirrorTable | None = None

    def set(self, params: Sequence[Parameter], atomic: bool, deadline: int = 0) -> list[SetResult]:
        assert self.table is not None
        self.table.apply_event([], [_Msg(p.name, p.value) for p in params], [])
        return super().set(params, atomic, deadline)


class _Msg:
    """A ``rcl_interfaces/Parameter`` as the events carry it (name and a ROS 2 value)."""

    def __init__(self, name: str, value: ParameterValue) -> None:
        from paramdds.ros2.messages import value_to_ros

        self.name = name
        self.value = value_to_ros(value)


def _last(table: MirrorTable) -> list[ChangeSet]:
    changes: list[ChangeSet] = []
    table.add_change_listener(changes.append)
    return changes


def test_what_the_node_reports_is_stamped_as_its_own_change() -> None:
    require_ros2()
    table = _mirrored(_Node())
    changes = _last(table)
    table.apply_event([], [_Msg("gain", _v(0.75))], [])
    table.resync({"gain": (_v(0.25), _gain())})
    assert [(c.origin.who, c.origin.via, c.origin.verified) for c in changes] == [
        ("/arm/driver", "ros2", False)
    ] * 2


def test_a_forwarded_set_keeps_its_asker_when_the_nodes_event_comes_first() -> None:
    require_ros2()
    from paramdds.core.origin import Origin, Via, acting

    node = _Echoing()
    table = node.table = _mirrored(node)
    changes = _last(table)
    with acting(Origin("alice", Via.CLI)):
        assert table.set([Parameter("gain", _v(0.75))]).results[0].successful
    # the event committed it (as alice's); the answer then found nothing left to commit
    assert [(c.origin.who, c.origin.via) for c in changes] == [("alice", "cli")]
    # an event for another value while nothing is forwarded is the node's own
    table.apply_event([], [_Msg("gain", _v(0.75)), _Msg("mode", _v("manual"))], [])
    assert [(c.origin.who, c.origin.via) for c in changes[1:]] == [("/arm/driver", "ros2")]
