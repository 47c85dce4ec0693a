"""Conversions between rcl_interfaces messages and the core, and ROS 2 reasons to codes."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import ErrorCode
from paramdds.ros2.bridge import matches
from paramdds.ros2.messages import code_of_reason

from .conftest import require_ros2

# reasons as rclpy 9 and rclcpp write them
REASONS = {
    "Trying to set a read-only parameter: frozen.": ErrorCode.READ_ONLY,
    "parameter 'frozen' cannot be set because it is read-only": ErrorCode.READ_ONLY,
    "Invalid access to undeclared parameter(s): nope": ErrorCode.NOT_FOUND,
    "parameter 'nope' cannot be set because it was not declared": ErrorCode.NOT_FOUND,
    "Wrong parameter type, expected 'Type.DOUBLE' got 'Type.STRING'": ErrorCode.TYPE_MISMATCH,
    "Static parameter cannot be undeclared": ErrorCode.TYPE_MISMATCH,
    "cannot undeclare a statically typed parameter": ErrorCode.TYPE_MISMATCH,
    "Parameter limits.speed out of range. Min: 0.0, Max: 5.0, value: 9.0": ErrorCode.OUT_OF_RANGE,
    "The parameter value for limits.count is not a valid step. Min: 0, max: 10, value: 3, step: 2": (
        ErrorCode.OUT_OF_RANGE
    ),
    "mode must be auto or manual, not 'bad'": ErrorCode.INVALID_VALUE,
    "": ErrorCode.INVALID_VALUE,
}


@pytest.mark.parametrize("reason", list(REASONS))
def test_ros2_reasons_map_to_paramdds_codes(reason: str) -> None:
    assert code_of_reason(reason) is REASONS[reason]


def test_globs_match_fully_qualified_names_with_or_without_the_slash() -> None:
    assert matches("/arm/driver", ["*"], [])
    assert matches("/arm/driver", ["/arm/*"], [])
    assert matches("/arm/driver", ["arm/*"], [])
    assert not matches("/arm/driver", ["*"], ["/arm/*"])
    assert not matches("/base/driver", ["/arm/*"], [])


def _values() -> st.SearchStrategy[ParameterValue]:
    i64 = st.integers(-(2**63), 2**63 - 1)
    floats = st.floats(allow_nan=False)
    text = st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=20)
    return st.one_of(
        st.just(ParameterValue(ParameterType.NOT_SET, None)),
        st.booleans().map(lambda v: ParameterValue(ParameterType.BOOL, v)),
        i64.map(lambda v: ParameterValue(ParameterType.INTEGER, v)),
        floats.map(lambda v: ParameterValue(ParameterType.DOUBLE, v)),
        text.map(lambda v: ParameterValue(ParameterType.STRING, v)),
        st.binary(max_size=8).map(lambda v: ParameterValue(ParameterType.BYTE_ARRAY, v)),
        st.lists(st.booleans(), max_size=4).map(lambda v: ParameterValue(ParameterType.BOOL_ARRAY, tuple(v))),
        st.lists(i64, max_size=4).map(lambda v: ParameterValue(ParameterType.INTEGER_ARRAY, tuple(v))),
        st.lists(floats, max_size=4).map(lambda v: ParameterValue(ParameterType.DOUBLE_ARRAY, tuple(v))),
        st.lists(text, max_size=4).map(lambda v: ParameterValue(ParameterType.STRING_ARRAY, tuple(v))),
    )


@given(_values())
def test_every_value_survives_the_rcl_interfaces_message(value: ParameterValue) -> None:
    require_ros2()
    from paramdds.ros2.messages import value_from_ros, value_to_ros

    assert value_from_ros(value_to_ros(value)) == value


def test_descriptors_survive_the_rcl_interfaces_message() -> None:
    require_ros2()
    from paramdds.ros2.messages import descriptor_from_ros, descriptor_to_ros

    for d in (
        ParameterDescriptor(
            "a", ParameterType.DOUBLE, "speed", "<= 5", floating_point_range=FloatingPointRange(0, 5, 0.5)
        ),
        ParameterDescriptor("b", ParameterType.INTEGER, read_only=True, integer_range=IntegerRange(-3, 9, 3)),
        ParameterDescriptor("c", ParameterType.STRING, dynamic_typing=True),
    ):
        assert descriptor_from_ros(descriptor_to_ros(d), d.name) == d


def test_bench_ros2_skips_with_the_reason_without_the_extra(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import paramdds.ros2
    from paramdds.cli import main

    monkeypatch.setattr(paramdds.ros2, "missing", lambda: "the ros2 extra is not installed (rclpy missing)")
    assert main(["bench", "ros2", "-o", "json"]) == 0
    out = capsys.readouterr()
    assert '"skipped": "the ros2 extra is not installed (rclpy missing)"' in out.out
    assert "skipped" in out.err


def test_the_ros2_verb_says_what_to_install_without_the_extra(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import paramdds.ros2
    from paramdds.cli import main

    monkeypatch.setattr(paramdds.ros2, "missing", lambda: "the ros2 extra is not installed (rclpy missing)")
    assert main(["ros2"]) == 2
    assert (
        "'paramdds ros2' cannot run: the ros2 extra is not installed (rclpy missing)"
        in capsys.readouterr().err
    )
