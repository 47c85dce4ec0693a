"""ParameterTable: declare, get, set, callbacks, revisions — ROS 2 semantics and the bugs we fix."""

from __future__ import annotations

import logging
import math
import threading

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core import (
    NOT_SET,
    ChangeKind,
    ChangeSet,
    FloatingPointRange,
    IntegerRange,
    Parameter,
    ParameterDescriptor,
    ParameterTable,
    ParameterType,
    ParameterValue,
    SetOutcome,
    SetVeto,
    Validator,
)
from paramdds.core.limits import MAX_PARAMETERS_PER_REQUEST, MAX_STRING_BYTES, MAX_VALUE_BYTES
from paramdds.errors import (
    AlreadyDeclaredError,
    CallbackError,
    ErrorCode,
    InvalidNameError,
    InvalidValueError,
    NotFoundError,
    OutOfRangeError,
    ParamddsError,
    ReadOnlyError,
    TooLargeError,
    TypeMismatchError,
)

T = ParameterType
V = ParameterValue.from_python


def P(name: str, value: object) -> Parameter:
    return Parameter(name, value if isinstance(value, ParameterValue) else V(value))


def state(table: ParameterTable) -> tuple[int, list[tuple[str, ParameterValue, ParameterDescriptor]]]:
    return table.revision, table.snapshot()


def same_state(a: tuple[int, list], b: tuple[int, list]) -> bool:  # type: ignore[type-arg]
    (ra, sa), (rb, sb) = a, b
    return (
        ra == rb
        and len(sa) == len(sb)
        and all(
            na == nb and va.same_as(vb) and da == db
            for (na, va, da), (nb, vb, db) in zip(sa, sb, strict=True)
        )
    )


def codes(outcome: SetOutcome) -> list[ErrorCode | None]:
    return [r.code for r in outcome.results]


# --- declaring ------------------------------------------------------------------------------------


def test_declare_returns_the_default_and_infers_a_static_type() -> None:
    t = ParameterTable("n")
    assert t.declare("speed", 1.5) == ParameterValue(T.DOUBLE, 1.5)
    d = t.describe_one("speed")
    assert (d.name, d.type, d.dynamic_typing) == ("speed", T.DOUBLE, False)
    assert t.has("speed") and len(t) == 1


def test_declare_fills_the_descriptor_name() -> None:
    t = ParameterTable("n")
    t.declare("a.b", 1, ParameterDescriptor("ignored", description="doc"))
    assert t.describe_one("a.b").name == "a.b"
    assert t.describe_one("a.b").description == "doc"


def test_an_override_wins_over_the_default_and_is_coerced_to_its_type() -> None:
    t = ParameterTable("n", overrides={"speed": V(3), "other": V("x")})
    assert t.declare("speed", 1.5) == ParameterValue(T.DOUBLE, 3.0)
    assert t.declare("other", "default", ignore_override=True) == V("default")


def test_a_strict_table_refuses_an_integer_override_for_a_double() -> None:
    t = ParameterTable("n", strict_types=True, overrides={"speed": V(50)})
    with pytest.raises(TypeMismatchError, match=r"50\.0"):
        t.declare("speed", 1.5)
    assert not t.has("speed") and t.revision == 0


def test_a_typed_parameter_may_be_declared_without_a_value_and_read_once_set() -> None:
    # rclcpp/rclpy: declare with a type and no value; reading fails until it is set.
    t = ParameterTable("n")
    assert t.declare("robot.id", None, ParameterDescriptor("", T.INTEGER)) is NOT_SET
    assert t.has("robot.id") and t.describe_one("robot.id").type is T.INTEGER
    with pytest.raises(InvalidValueError, match=r"'robot.id' is declared \(integer\) but has no value"):
        t.get("robot.id")
    assert t.get_many(["robot.id"])[0].value is NOT_SET
    assert not t.set([Parameter("robot.id", V("x"))]).results[0].successful  # still typed
    assert t.set([Parameter("robot.id", V(3))]).results[0].successful
    assert t.get("robot.id") == V(3)
    t2 = ParameterTable("n", overrides={"robot.id": V(7)})
    assert t2.has_override("robot.id") and not t2.has_override("other")
    assert t2.declare("robot.id", None, ParameterDescriptor("", T.INTEGER)) == V(7)


def test_not_set_on_an_unset_dynamic_parameter_keeps_it_declared_and_changes_nothing() -> None:
    t = ParameterTable("n")
    t.declare("x", None, ParameterDescriptor("", dynamic_typing=True))
    revision = t.revision
    outcome = t.set([Parameter("x", NOT_SET)])
    assert outcome.results[0].successful and t.has("x") and t.revision == revision
    t.set([Parameter("x", V(1))])
    assert t.set([Parameter("x", NOT_SET)]).results[0].successful and not t.has("x")  # a value: deleted


def test_a_parameter_with_no_type_at_all_is_refused() -> None:
    # rclcpp's declare_parameter_helper throws InvalidParameterTypeException, even when an
    # override would give a value (issue 20, kind 4)
    with pytest.raises(TypeMismatchError, match="has no type"):
        ParameterTable("n").declare("x")
    with pytest.raises(TypeMismatchError, match="has no type"):
        ParameterTable("n", overrides={"x": ParameterValue(T.INTEGER, 1)}).declare("x")


def test_a_dynamically_typed_parameter_may_start_unset() -> None:
    t = ParameterTable("n")
    assert t.declare("x", None, ParameterDescriptor("", dynamic_typing=True)) is NOT_SET
    assert t.has("x") and t.get_types(["x"]) == [T.NOT_SET]


def test_declare_validates_the_default_and_the_override() -> None:
    d = ParameterDescriptor("", T.INTEGER, integer_range=IntegerRange(0, 10, 0))
    with pytest.raises(OutOfRangeError, match="'x' with value 11"):
        ParameterTable("n").declare("x", 11, d)
    with pytest.raises(OutOfRangeError, match="'x' with value -1"):
        ParameterTable("n", overrides={"x": V(-1)}).declare("x", 5, d)


def test_declare_refuses_bad_names_duplicates_descriptors_and_sizes() -> None:
    t = ParameterTable("n")
    t.declare("x", 1)
    with pytest.raises(AlreadyDeclaredError, match="'x' is already declared"):
        t.declare("x", 2)
    with pytest.raises(InvalidNameError):
        t.declare("a..b", 1)
    with pytest.raises(InvalidValueError, match="'gt' does not apply to a string"):
        t.declare("s", "x", ParameterDescriptor("", validators=(Validator("gt", (V(1),)),)))
    with pytest.raises(TooLargeError, match="description"):
        t.declare("d", 1, ParameterDescriptor("", description="x" * (MAX_STRING_BYTES + 1)))
    with pytest.raises(TooLargeError, match="'big'"):
        t.declare("big", b"x" * (MAX_VALUE_BYTES + 1))
    assert t.names() == ["x"] and t.revision == 1


def test_overrides_with_invalid_names_are_refused_at_once() -> None:
    with pytest.raises(InvalidNameError):
        ParameterTable("n", overrides={"bad name": V(1)})


def test_use_sim_time_is_off_by_default() -> None:
    assert ParameterTable("n").names() == []
    t = ParameterTable("n", use_sim_time=True)
    assert t.get("use_sim_time") == V(False)


# --- revisions and change sets --------------------------------------------------------------------


def test_every_commit_is_one_change_set_with_the_next_revision() -> None:
    t = ParameterTable("node1")
    seen: list[ChangeSet] = []
    t.add_change_listener(seen.append)
    t.declare("a", 1, ParameterDescriptor("", dynamic_typing=True))
    t.declare_from([("b", V(2), None), ("c", V("x"), ParameterDescriptor("", read_only=True))])
    t.set([P("a", 5)])
    t.undeclare("a")
    assert [c.revision for c in seen] == [1, 2, 3, 4] and t.revision == 4
    assert [[(ch.kind, ch.name) for ch in c.changes] for c in seen] == [
        [(ChangeKind.NEW, "a")],
        [(ChangeKind.NEW, "b"), (ChangeKind.NEW, "c")],
        [(ChangeKind.CHANGED, "a")],
        [(ChangeKind.DELETED, "a")],
    ]
    assert seen[3].changes[0].value is NOT_SET
    assert all(c.node_id == "node1" for c in seen)


def test_declare_from_is_all_or_nothing() -> None:
    t = ParameterTable("n")
    with pytest.raises(AlreadyDeclaredError):
        t.declare_from([("a", V(1), None), ("a", V(2), None)])
    with pytest.raises(OutOfRangeError):
        ranged = ParameterDescriptor("", integer_range=IntegerRange(0, 10, 0))
        t.declare_from([("a", V(1), None), ("b", V(20), ranged)])
    assert t.names() == [] and t.revision == 0


def test_undeclare_follows_ros_rules() -> None:
    t = ParameterTable("n")
    t.declare("static", 1)
    t.declare("ro", 1, ParameterDescriptor("", read_only=True, dynamic_typing=True))
    with pytest.raises(NotFoundError):
        t.undeclare("nope")
    with pytest.raises(TypeMismatchError, match="statically typed"):
        t.undeclare("static")
    with pytest.raises(ReadOnlyError):
        t.undeclare("ro")
    assert t.names() == ["ro", "static"]


# --- reading ------------------------------------------------------------------------------------


def test_get_and_describe_raise_not_found() -> None:
    t = ParameterTable("n")
    with pytest.raises(NotFoundError, match="'x' is not declared"):
        t.get("x")
    with pytest.raises(NotFoundError):
        t.describe_one("x")
    with pytest.raises(InvalidNameError):
        t.get("bad name")


def test_get_many_reports_a_status_for_every_name() -> None:
    t = ParameterTable("n")
    t.declare("a", 1)
    results = t.get_many(["missing", "a", "bad..name"], with_descriptors=True)
    assert [r.name for r in results] == ["missing", "a", "bad..name"]
    assert [r.code for r in results] == [ErrorCode.NOT_FOUND, None, ErrorCode.INVALID_NAME]
    assert results[0].value is None and "'missing' is not declared" in results[0].reason
    assert results[1].value == V(1) and results[1].descriptor == t.describe_one("a")
    assert "empty segment" in results[2].reason
    assert t.get_many(["a"])[0].descriptor is None


def test_get_types_reports_not_set_for_unknown_names() -> None:
    t = ParameterTable("n")
    t.declare("a", [1.0])
    assert t.get_types(["a", "b"]) == [T.DOUBLE_ARRAY, T.NOT_SET]


def test_snapshot_and_names_are_sorted() -> None:
    t = ParameterTable("n")
    for name in ["b", "a.z", "a"]:
        t.declare(name, 1)
    assert t.names() == ["a", "a.z", "b"]
    assert [n for n, _, _ in t.snapshot()] == ["a", "a.z", "b"]


# --- setting ------------------------------------------------------------------------------------


@pytest.fixture
def table() -> ParameterTable:
    t = ParameterTable("robot")
    t.declare("speed", 1.0, ParameterDescriptor("", floating_point_range=FloatingPointRange(0.0, 5.0)))
    t.declare("count", 1)
    t.declare("name", "r2", ParameterDescriptor("", read_only=True))
    t.declare("any", 1, ParameterDescriptor("", dynamic_typing=True))
    return t


def test_set_applies_each_parameter_independently_in_one_revision(table: ParameterTable) -> None:
    before = table.revision
    out = table.set([P("speed", 9.0), P("count", 3), P("speed", 2.0)])
    assert [r.successful for r in out.results] == [False, True, True]
    assert out.results[0].code is ErrorCode.OUT_OF_RANGE
    assert "'speed' with value 9.0" in out.results[0].reason
    assert out.revision == before + 1 == table.revision
    assert out.change is not None and [c.name for c in out.change.changes] == ["count", "speed"]
    assert table.get("speed") == V(2.0) and table.get("count") == V(3)


def test_an_integer_for_a_double_is_widened_not_a_crash(table: ParameterTable) -> None:
    out = table.set([P("speed", 2)])
    assert out.results[0].successful
    assert table.get("speed") == ParameterValue(T.DOUBLE, 2.0)


def test_a_strict_table_tells_to_write_a_double() -> None:
    t = ParameterTable("n", strict_types=True)
    t.declare("speed", 1.0)
    out = t.set([P("speed", 50)])
    assert out.results[0].code is ErrorCode.TYPE_MISMATCH
    assert "50.0" in out.results[0].reason and "'speed'" in out.results[0].reason
    assert t.get("speed") == V(1.0)


def test_a_double_for_an_integer_is_a_type_mismatch(table: ParameterTable) -> None:
    out = table.set([P("count", 2.0)])
    assert codes(out) == [ErrorCode.TYPE_MISMATCH]
    assert "expects a integer but got double 2.0" in out.results[0].reason


def test_dynamic_typing_allows_a_type_change(table: ParameterTable) -> None:
    assert table.set([P("any", "now a string")]).results[0].successful
    assert table.describe_one("any").type is T.STRING
    assert table.get("any") == V("now a string")


def test_setting_an_undeclared_name_says_how_to_allow_it(table: ParameterTable) -> None:
    out = table.set([P("new", 1)])
    assert codes(out) == [ErrorCode.NOT_FOUND]
    assert out.results[0].reason == (
        "parameter 'new' is not declared (start the node with --allow-undeclared to accept new names)"
    )
    assert out.change is None


def test_allow_undeclared_declares_a_dynamically_typed_parameter() -> None:
    t = ParameterTable("n", allow_undeclared=True)
    out = t.set([P("new", 1)])
    assert out.results[0].successful and out.change is not None
    assert out.change.changes[0].kind is ChangeKind.NEW
    assert t.describe_one("new").dynamic_typing
    assert t.set([P("new", "text")]).results[0].successful


def test_setting_not_set_deletes_a_dynamic_parameter_only(table: ParameterTable) -> None:
    out = table.set([P("any", NOT_SET), P("count", NOT_SET), P("ghost", NOT_SET)])
    assert codes(out) == [None, ErrorCode.TYPE_MISMATCH, ErrorCode.NOT_FOUND]
    assert "cannot be deleted" in out.results[1].reason
    assert out.change is not None and out.change.changes[0].kind is ChangeKind.DELETED
    assert not table.has("any") and table.has("count")


def test_read_only_parameters_and_tables(table: ParameterTable) -> None:
    out = table.set([P("name", "c3po")])
    assert codes(out) == [ErrorCode.READ_ONLY]
    assert "'name' is read-only" in out.results[0].reason
    ro = ParameterTable("arm", read_only=True)
    ro.declare("x", 1, ParameterDescriptor("", dynamic_typing=True))
    out = ro.set([P("x", 2), P("x", NOT_SET)])
    assert codes(out) == [ErrorCode.READ_ONLY, ErrorCode.READ_ONLY]
    assert out.results[0].reason == "node 'arm' is read-only"
    assert ro.get("x") == V(1)


def test_a_static_type_cannot_change(table: ParameterTable) -> None:
    out = table.set([P("count", "three")])
    assert codes(out) == [ErrorCode.TYPE_MISMATCH]


def test_invalid_names_and_sizes_become_results_not_exceptions(table: ParameterTable) -> None:
    out = table.set([P("bad name", 1), P("count", [1] * (MAX_VALUE_BYTES // 8 + 1)), P("count", 4)])
    assert codes(out) == [ErrorCode.INVALID_NAME, ErrorCode.TOO_LARGE, None]
    assert table.get("count") == V(4)


def test_too_many_parameters_fail_together() -> None:
    t = ParameterTable("n")
    t.declare("a", 1)
    out = t.set([P("a", 2)] * (MAX_PARAMETERS_PER_REQUEST + 1))
    assert len(out.results) == MAX_PARAMETERS_PER_REQUEST + 1
    assert {r.code for r in out.results} == {ErrorCode.TOO_LARGE}
    assert t.get("a") == V(1)


def test_set_atomically_is_all_or_nothing(table: ParameterTable) -> None:
    before = state(table)
    out = table.set_atomically([P("count", 2), P("speed", 7.0), P("any", "x")])
    assert [r.successful for r in out.results] == [False, False, False]
    assert out.results[1].code is ErrorCode.OUT_OF_RANGE
    assert out.results[0].reason == "not applied: the atomic set failed on 'speed'"
    assert out.results[2].reason == "not applied: the atomic set failed on 'speed'"
    assert out.change is None and same_state(before, state(table))
    ok = table.set_atomically([P("count", 2), P("speed", 4.0)])
    assert all(r.successful for r in ok.results) and ok.revision == before[0] + 1
    assert ok.change is not None and len(ok.change.changes) == 2


def test_expected_revision_is_compare_and_set(table: ParameterTable) -> None:
    rev = table.revision
    for method in (table.set, table.set_atomically):
        out = method([P("count", 5), P("speed", 1.0)], expected_revision=rev - 1)
        assert codes(out) == [ErrorCode.CONFLICT, ErrorCode.CONFLICT]
        assert f"at revision {rev}, not the expected {rev - 1}" in out.results[0].reason
        assert table.get("count") == V(1) and table.revision == rev
    assert table.set([P("count", 5)], expected_revision=rev).results[0].successful


def test_set_refuses_a_non_list_with_our_error(table: ParameterTable) -> None:
    with pytest.raises(InvalidValueError):
        table.set(P("count", 1))  # type: ignore[arg-type]


def test_malformed_entries_fail_one_by_one(table: ParameterTable) -> None:
    out = table.set([1, Parameter("count", 3), Parameter(5, V(1))])  # type: ignore[list-item, arg-type]
    assert codes(out) == [ErrorCode.INVALID_VALUE, None, ErrorCode.INVALID_NAME]
    assert "expected a Parameter, got int" in out.results[0].reason


# --- callbacks ------------------------------------------------------------------------------------


def test_callbacks_run_in_order_and_see_stored_values(table: ParameterTable) -> None:
    log: list[str] = []

    def pre(ps: list[Parameter]) -> list[Parameter]:
        log.append(f"pre {[p.name for p in ps]}")
        return ps

    def on(ps: list[Parameter]) -> SetVeto:
        log.append(f"on {[(p.name, p.value.value) for p in ps]} rev={table.revision}")
        return SetVeto(True)

    table.add_pre_set_callback(pre)
    table.add_on_set_callback(on)
    table.add_change_listener(lambda c: log.append(f"listener rev={c.revision}"))
    table.add_post_set_callback(lambda ps: log.append(f"post {[p.name for p in ps]} rev={table.revision}"))
    rev = table.revision
    table.set([P("speed", 2), P("count", 3)])
    assert log == [
        "pre ['speed']",
        f"on [('speed', 2.0)] rev={rev}",
        "pre ['count']",
        f"on [('count', 3)] rev={rev}",
        f"listener rev={rev + 1}",
        f"post ['speed', 'count'] rev={rev + 1}",
    ]


def test_the_last_registered_callback_runs_first_and_can_be_removed(table: ParameterTable) -> None:
    order: list[int] = []
    first = table.add_on_set_callback(lambda ps: order.append(1) or SetVeto(True))
    table.add_on_set_callback(lambda ps: order.append(2) or SetVeto(True))
    table.set([P("count", 2)])
    assert order == [2, 1]
    table.remove_callback(first)
    table.set([P("count", 3)])
    assert order == [2, 1, 2]
    with pytest.raises(NotFoundError):
        table.remove_callback(first)


def test_pre_set_may_rewrite_and_add_parameters(table: ParameterTable) -> None:
    def clamp_and_count(ps: list[Parameter]) -> list[Parameter]:
        out = [P("speed", 5.0) if p.name == "speed" and p.value.value > 5.0 else p for p in ps]  # type: ignore[operator]
        return [*out, P("count", 42)]

    table.add_pre_set_callback(clamp_and_count)
    out = table.set([P("speed", 100.0)])
    assert out.results[0].successful and len(out.results) == 1
    assert table.get("speed") == V(5.0) and table.get("count") == V(42)


def test_pre_set_removing_everything_fails_the_request(table: ParameterTable) -> None:
    table.add_pre_set_callback(lambda ps: [])
    out = table.set([P("count", 2)])
    assert not out.results[0].successful
    assert "left no parameter to set" in out.results[0].reason and table.get("count") == V(1)


def test_an_on_set_veto_fails_only_its_parameter_in_a_plain_set(table: ParameterTable) -> None:
    def no_fast(ps: list[Parameter]) -> SetVeto:
        fast = any(p.name == "speed" and p.value.value == 4.0 for p in ps)
        return SetVeto(False, "too fast for indoors") if fast else SetVeto(True)

    table.add_on_set_callback(no_fast)
    out = table.set([P("speed", 4.0), P("count", 2)])
    assert [r.successful for r in out.results] == [False, True]
    assert out.results[0].reason == "too fast for indoors"
    assert out.results[0].code is ErrorCode.INVALID_VALUE
    atomic = table.set_atomically([P("speed", 4.0), P("count", 3)])
    assert [r.reason for r in atomic.results] == ["too fast for indoors"] * 2
    assert table.get("count") == V(2) and table.get("speed") == V(1.0)


def test_the_on_set_reason_is_kept_on_success(table: ParameterTable) -> None:
    table.add_on_set_callback(lambda ps: SetVeto(True, "applied after the next cycle"))
    out = table.set([P("count", 2)])
    assert out.results[0].successful and out.results[0].reason == "applied after the next cycle"
    out = table.set_atomically([P("count", 3)])
    assert out.results[0].reason == "applied after the next cycle"


def test_an_exception_in_a_callback_fails_the_set_and_changes_nothing(table: ParameterTable) -> None:
    def boom(ps: list[Parameter]) -> SetVeto:
        raise RuntimeError("sensor offline")

    table.add_on_set_callback(boom)
    before = state(table)
    out = table.set([P("count", 2)])
    assert not out.results[0].successful
    assert out.results[0].reason == "on-set callback failed: RuntimeError: sensor offline"
    assert same_state(before, state(table))


def test_a_pre_set_exception_or_bad_return_fails_the_set(table: ParameterTable) -> None:
    handle = table.add_pre_set_callback(lambda ps: 1 / 0)  # type: ignore[arg-type, return-value]
    out = table.set([P("count", 2)])
    assert "pre-set callback failed: ZeroDivisionError" in out.results[0].reason
    table.remove_callback(handle)
    table.add_pre_set_callback(lambda ps: None)  # type: ignore[arg-type, return-value]
    out = table.set_atomically([P("count", 2)])
    assert "expected a list of Parameter" in out.results[0].reason and table.get("count") == V(1)


def test_post_set_and_listener_failures_are_logged_not_raised(
    table: ParameterTable, caplog: pytest.LogCaptureFixture
) -> None:
    def bad_listener(change: ChangeSet) -> None:
        raise RuntimeError("writer gone")

    def bad_post(ps: list[Parameter]) -> None:
        raise ValueError("late")

    table.add_change_listener(bad_listener)
    table.add_post_set_callback(bad_post)
    with caplog.at_level(logging.ERROR):
        out = table.set([P("count", 2)])
    assert out.results[0].successful and table.get("count") == V(2)
    assert out.results[0].reason == "applied, but a post-set callback failed: ValueError: late"
    assert "writer gone" in caplog.text and "late" in caplog.text


def test_changing_parameters_from_a_callback_raises_callback_error(table: ParameterTable) -> None:
    caught: list[ParamddsError] = []

    def meddle(ps: list[Parameter]) -> SetVeto:
        for action in (
            lambda: table.set([P("count", 9)]),
            lambda: table.declare("z", 1),
            lambda: table.undeclare("any"),
            lambda: table.add_on_set_callback(meddle),
        ):
            try:
                action()
            except CallbackError as exc:
                caught.append(exc)
        assert table.get("count") == V(1)  # reading is fine
        return SetVeto(True)

    table.add_on_set_callback(meddle)
    assert table.set([P("count", 2)]).results[0].successful
    assert len(caught) == 4
    assert all(e.code is ErrorCode.IN_CALLBACK for e in caught)
    assert "from inside a parameter callback" in caught[0].message
    assert table.get("count") == V(2) and not table.has("z")


def test_an_escaping_callback_error_fails_the_set_with_its_code(table: ParameterTable) -> None:
    table.add_on_set_callback(lambda ps: table.set([]) and SetVeto(True))  # type: ignore[func-returns-value]
    out = table.set([P("count", 2)])
    assert out.results[0].code is ErrorCode.IN_CALLBACK
    assert table.get("count") == V(1)


def test_declare_runs_on_set_and_a_veto_refuses_it() -> None:
    t = ParameterTable("n")
    seen: list[str] = []
    t.add_on_set_callback(lambda ps: SetVeto(not seen.append(ps[0].name) and ps[0].name != "bad_one", "no"))
    t.declare("good", 1)
    with pytest.raises(InvalidValueError, match="no"):
        t.declare("bad_one", 1)
    assert seen == ["good", "bad_one"] and t.names() == ["good"] and t.revision == 1


def test_listeners_cannot_change_parameters_either(table: ParameterTable) -> None:
    errors: list[CallbackError] = []

    def listener(change: ChangeSet) -> None:
        try:
            table.declare("late", 1)
        except CallbackError as exc:
            errors.append(exc)

    table.add_change_listener(listener)
    table.set([P("count", 2)])
    assert len(errors) == 1 and not table.has("late")


# --- threads --------------------------------------------------------------------------------------


def test_concurrent_sets_commit_each_request_once_in_order() -> None:
    t = ParameterTable("n")
    t.declare_from([(f"p{i}", V(0), None) for i in range(8)])
    revisions: list[int] = []
    t.add_change_listener(lambda c: revisions.append(c.revision))
    start = t.revision

    def worker(i: int) -> None:
        for k in range(200):
            t.set_atomically([P(f"p{i}", k + 1), P(f"p{(i + 1) % 8}", k + 1)])

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert revisions == list(range(start + 1, start + 1 + 8 * 200))
    assert t.revision == start + 1600
    assert all(t.get(f"p{i}") == V(200) for i in range(8))


# --- properties -----------------------------------------------------------------------------------


def _table() -> ParameterTable:
    t = ParameterTable("prop")
    t.declare("i", 5, ParameterDescriptor("", integer_range=IntegerRange(0, 10, 5)))
    t.declare("d", math.nan)
    t.declare("s", "a", ParameterDescriptor("", validators=(Validator("one_of", (V(["a", "b"]),)),)))
    t.declare("ro", 1, ParameterDescriptor("", read_only=True))
    t.declare("dyn", [1.0], ParameterDescriptor("", dynamic_typing=True))
    return t


values = st.one_of(
    st.just(NOT_SET),
    st.integers(min_value=-20, max_value=20).map(V),
    st.floats().map(V),
    st.sampled_from(["a", "b", "c"]).map(V),
    st.lists(st.integers(min_value=0, max_value=3), min_size=1, max_size=3).map(V),
)
names = st.sampled_from(["i", "d", "s", "ro", "dyn", "ghost", "bad..name"])
requests = st.lists(st.builds(Parameter, names, values), max_size=5)


@settings(max_examples=300)
@given(requests, st.booleans(), st.sampled_from([None, 5, 4]))
def test_a_set_that_commits_nothing_changes_nothing(
    request: list[Parameter], atomic: bool, expected: int | None
) -> None:
    t = _table()
    before = state(t)
    out = (t.set_atomically if atomic else t.set)(request, expected_revision=expected)
    assert len(out.results) == len(request)
    assert [r.name for r in out.results] == [p.name for p in request]
    assert all((r.code is None) == r.successful for r in out.results)
    if out.change is None:
        assert same_state(before, state(t))
    else:
        assert out.revision == t.revision == before[0] + 1
        assert any(r.successful for r in out.results)
        if atomic:
            assert all(r.successful for r in out.results)


anything = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text() | st.binary() | st.builds(object),
    lambda inner: st.lists(inner, max_size=3) | st.tuples(inner, inner),
    max_leaves=6,
)


@settings(max_examples=200)
@given(st.lists(st.one_of(anything, st.builds(Parameter, anything, anything)), max_size=4), st.booleans())
def test_arbitrary_input_to_set_yields_results_or_our_errors(items: list[object], atomic: bool) -> None:
    t = ParameterTable("n", allow_undeclared=True)
    t.declare("x", 1)
    try:
        out = (t.set_atomically if atomic else t.set)(items)  # type: ignore[arg-type]
    except ParamddsError:
        return
    assert len(out.results) == len(items)
    assert all(isinstance(r.name, str) for r in out.results)


def test_an_empty_request_commits_nothing(table: ParameterTable) -> None:
    rev = table.revision
    for method in (table.set, table.set_atomically):
        out = method([])
        assert out.results == () and out.change is None and out.revision == rev


def test_undeclare_tells_listeners_but_runs_no_set_callbacks(table: ParameterTable) -> None:
    post: list[list[Parameter]] = []
    changes: list[ChangeSet] = []
    table.add_post_set_callback(post.append)
    table.add_change_listener(changes.append)
    table.undeclare("any")
    assert post == []
    assert [(c.kind, c.name) for c in changes[0].changes] == [(ChangeKind.DELETED, "any")]


def test_name_lists_must_be_lists(table: ParameterTable) -> None:
    with pytest.raises(InvalidValueError, match="list of parameter names"):
        table.get_many("count")
    with pytest.raises(InvalidValueError, match="list of parameter names"):
        table.get_types("count")


def test_not_set_for_an_undeclared_name_declares_it_without_a_value_when_allowed() -> None:
    # rclcpp's set_parameters_atomically declares it (issue 20, kind 1); inside an atomic set too
    t = ParameterTable("n", allow_undeclared=True)
    assert t.set_atomically([Parameter("ghost", NOT_SET), Parameter("b", V(1))]).results[0].successful
    assert t.has("ghost") and t.get_types(["ghost"]) == [T.NOT_SET] and t.get("b") == V(1)


def test_an_atomic_set_reports_the_first_undeclared_or_read_only_name_before_any_type() -> None:
    # rclcpp checks "declared" and "read-only" for every entry before any value (kind 2)
    t = ParameterTable("n")
    t.declare("a", 1)
    results = t.set_atomically([Parameter("a", V("wrong type")), Parameter("ghost", V(1))]).results
    assert [r.code for r in results] == [ErrorCode.INVALID_VALUE, ErrorCode.NOT_FOUND]


def test_a_declaration_by_type_cannot_ask_for_dynamic_typing() -> None:
    # rclcpp's declare_parameter(name, type, descriptor): std::invalid_argument, before the
    # already-declared check (kind 5)
    t = ParameterTable("n")
    typed_dynamic = ParameterDescriptor("", T.INTEGER, dynamic_typing=True)
    with pytest.raises(InvalidValueError, match="dynamic_typing"):
        t.declare("x", None, typed_dynamic)
    t.declare("y", 1)
    with pytest.raises(InvalidValueError, match="dynamic_typing"):
        t.declare("y", None, typed_dynamic)
