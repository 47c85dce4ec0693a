"""Spec features beyond the plain leaf: mapped parameters, custom validators, implied ranges."""

from __future__ import annotations

import logging

import pytest

from paramdds.core.custom_validators import lookup_validator, register_validator, registered_validators
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter
from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.errors import FileFormatError, InvalidValueError
from paramdds.formats.spec import declare_spec, load_spec_str

MAPPED = """\
ns:
  joints:
    type: string_array
    default_value: [j1]
  gains:
    __map_joints:
      p:
        type: double
        default_value: 1.0
        validation:
          gt_eq<>: 0.0
"""


def test_mapped_parameters_follow_the_key_array_at_runtime() -> None:
    table = ParameterTable("n", overrides={"gains.j3.p": PV(T.DOUBLE, 3.0)})
    declare_spec(table, load_spec_str(MAPPED))
    assert table.names() == ["gains.j1.p", "joints"]
    revision = table.revision
    outcome = table.set([Parameter("joints", PV(T.STRING_ARRAY, ("j2", "j3", "j2")))])
    assert outcome.results[0].successful and outcome.revision == revision + 1
    # new entries are declared right after the set (their default, or an override), in a revision of
    # their own; the removed entry stays declared, as generate_parameter_library does
    assert table.names() == ["gains.j1.p", "gains.j2.p", "gains.j3.p", "joints"]
    assert table.get("gains.j2.p") == PV(T.DOUBLE, 1.0)
    assert table.get("gains.j3.p") == PV(T.DOUBLE, 3.0)
    assert table.revision == revision + 2
    assert not table.set([Parameter("gains.j2.p", PV(T.DOUBLE, -1.0))]).results[0].successful


def test_a_mapped_entry_that_is_not_a_valid_name_is_logged_and_the_set_still_applies(
    caplog: pytest.LogCaptureFixture,
) -> None:
    table = ParameterTable("n")
    declare_spec(table, load_spec_str(MAPPED))
    with caplog.at_level(logging.ERROR):
        outcome = table.set([Parameter("joints", PV(T.STRING_ARRAY, ("bad name", "j1")))])
    assert outcome.results[0].successful and table.get("joints") == PV(T.STRING_ARRAY, ("bad name", "j1"))
    assert "commit hook" in caplog.text and not table.has("gains.bad name.p")


def test_a_registered_custom_validator_is_enforced_and_one_that_raises_refuses_the_value() -> None:
    def even(value: PV, args: tuple[PV, ...]) -> str | None:
        assert isinstance(value.value, int)
        return None if value.value % 2 == 0 else "be even"

    def broken(value: PV, args: tuple[PV, ...]) -> str | None:
        raise ZeroDivisionError("oops")

    register_validator("tests_ext::even", even, replace=True)
    register_validator("tests_ext::broken", broken, replace=True)
    assert lookup_validator("tests_ext::even") is even and "tests_ext::even" in registered_validators()
    text = "ns:\n  k:\n    type: int\n    default_value: 2\n    validation:\n      tests_ext::even<>: null\n"
    table = ParameterTable("n")
    declare_spec(table, load_spec_str(text, strict=True))
    assert table.set([Parameter("k", PV(T.INTEGER, 4))]).results[0].successful
    refused = table.set([Parameter("k", PV(T.INTEGER, 5))]).results[0]
    assert not refused.successful and refused.reason == "Parameter 'k' with value 5 must be even"
    broken_spec = text.replace("tests_ext::even", "tests_ext::broken")
    table2 = ParameterTable("n")
    with pytest.raises(InvalidValueError, match="ZeroDivisionError: oops"):
        declare_spec(table2, load_spec_str(broken_spec))
    assert not table2.has("k")


@pytest.mark.parametrize("name", ["even", "ns::even<>", ""])
def test_register_validator_refuses_names_that_are_not_ns_function(name: str) -> None:
    with pytest.raises(InvalidValueError, match="namespace::function"):
        register_validator(name, lambda v, a: None)


def test_register_validator_refuses_a_taken_name_unless_replace() -> None:
    with pytest.raises(InvalidValueError, match="already registered"):
        register_validator("control_filters::gt_eq_or_nan", lambda v, a: None)


def test_an_unknown_custom_validator_warns_is_shown_as_not_enforced_and_strict_refuses_it(
    caplog: pytest.LogCaptureFixture,
) -> None:
    text = "ns:\n  k:\n    type: double\n    default_value: 1.0\n    validation:\n      acme::check<>: [2]\n"
    with caplog.at_level(logging.WARNING):
        spec = load_spec_str(text, source="s.yaml")
    assert "acme::check" in caplog.text and "NOT be enforced" in caplog.text
    assert spec.unenforced == ("acme::check",)
    (entry,) = spec
    assert entry.descriptor.additional_constraints == ""  # generate_parameter_library: the spec's key only
    table = ParameterTable("n")
    declare_spec(table, spec)
    assert table.set([Parameter("k", PV(T.DOUBLE, -5.0))]).results[0].successful  # not enforced
    with pytest.raises(FileFormatError, match="'acme::check' is not registered") as info:
        load_spec_str(text, source="s.yaml", strict=True)
    assert info.value.line == 6


def test_exclusive_bounds_fill_the_range_at_the_bound_and_the_validator_keeps_it_out() -> None:
    text = "ns:\n  d:\n    type: double\n    default_value: 0.5\n    validation:\n"
    text += "      gt<>: [0.0]\n      lt<>: [1.0]\n"
    table = ParameterTable("n")
    declare_spec(table, load_spec_str(text))
    r = table.describe_one("d").floating_point_range
    assert r is not None and (r.from_value, r.to_value) == (0.0, 1.0)
    assert not table.set([Parameter("d", PV(T.DOUBLE, 0.0))]).results[0].successful  # in the range, not > 0
    assert table.set([Parameter("d", PV(T.DOUBLE, 0.25))]).results[0].successful


def test_the_example_validators_module_registers_a_working_validator() -> None:
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "custom_validators.py"
    spec_ = importlib.util.spec_from_file_location("example_custom_validators", path)
    assert spec_ is not None and spec_.loader is not None
    spec_.loader.exec_module(importlib.util.module_from_spec(spec_))
    text = "ns:\n  rpm:\n    type: int\n    default_value: 10\n    validation:\n"
    table = ParameterTable("n")
    declare_spec(table, load_spec_str(text + "      robot::multiple_of<>: 5\n", strict=True))
    assert table.set([Parameter("rpm", PV(T.INTEGER, 15))]).results[0].successful
    refused = table.set([Parameter("rpm", PV(T.INTEGER, 12))]).results[0]
    assert not refused.successful and refused.reason.endswith("must be a multiple of 5")
