"""Real parameter files and generate_parameter_library specs (../shared/realworld, see its SOURCES.md).

Every file there loads for the nodes it configures, describes, accepts a valid set and
refuses an invalid one. Specs load with their companion parameter file where SOURCES.md
names one, otherwise with a fill file this test writes (values for the required
parameters and for read-only defaults their own validators refuse). The files are read
where CI puts them, beside the clone (``<repo>/../shared/realworld``); they are not copied.
The test skips (with the reason) only where that directory is absent; CI has it.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import pytest
import yaml

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.validation import validate
from paramdds.core.values import Parameter, ParameterType, ParameterValue
from paramdds.errors import FileFormatError, ParamddsError
from paramdds.formats.ros import load_ros_file_full, load_ros_params
from paramdds.formats.spec import Spec, SpecEntry, declare_spec, load_spec

_REPO = Path(__file__).resolve().parents[2]
# CI: beside the clone; a git worktree under <checkout>/wt/<name> finds it one level further up.
_PLACES = (_REPO.parent / "shared" / "realworld", _REPO.parent.parent / "shared" / "realworld")
REALWORLD = next((p for p in _PLACES if p.is_dir()), _PLACES[0])
pytestmark = pytest.mark.skipif(not REALWORLD.is_dir(), reason=f"{REALWORLD} is absent (CI has it)")
T = ParameterType

# Parameter files: the nodes each configures (node ids as a server would host them).
PARAM_FILES = {
    "nav2_params.yaml": ["amcl", "controller_server", "local_costmap/local_costmap", "bt_navigator"],
    "ur_controllers.yaml": ["controller_manager", "joint_trajectory_controller"],
    "ekf.yaml": ["ekf_filter_node"],
    "driver_params.yaml": ["ouster/os_driver"],
    "multi_controller_manager_rrbot_generic_controllers.yaml": [
        "rrbot_1/controller_manager",
        "rrbot_2/forward_position_controller",
        "rrbot_1/position_trajectory_controller",
        "controller_manager",  # /**/controller_manager matches no namespace at all too
    ],
    "diffbot_controllers.yaml": ["diffbot_base_controller"],
}
# Specs: (companion parameter file, node) per SOURCES.md, or None for a fill file.
SPECS = {
    "joint_trajectory_controller_parameters.yaml": (
        "multi_controller_manager_rrbot_generic_controllers.yaml",
        "rrbot_1/position_trajectory_controller",
    ),
    "diff_drive_controller_parameter.yaml": ("diffbot_controllers.yaml", "diffbot_base_controller"),
    "admittance_controller_parameters.yaml": None,
    "tricycle_controller_parameter.yaml": None,
}


def _text(name: str) -> str:
    text = (REALWORLD / name).read_text(encoding="utf-8")
    # ur_controllers.yaml is a launch template; its launch substitutes tf_prefix (default "").
    return text.replace("$(var tf_prefix)", "")


def _candidates(ptype: ParameterType, current: ParameterValue) -> list[ParameterValue]:
    """Values to try for a parameter, the current one last."""
    raw: list[object]
    if ptype is T.DOUBLE:
        raw = [0.5, 1.0, 2.0, 10.0, 0.0, -1.0]
    elif ptype is T.INTEGER:
        raw = [1, 2, 10, 100, 0]
    elif ptype is T.BOOL:
        raw = [True, False]
    elif ptype is T.STRING:
        raw = ["position", "base_link", "x"]
    elif ptype is T.STRING_ARRAY:
        raw = [["position"], ["joint1", "joint2"]]
    elif ptype is T.DOUBLE_ARRAY:
        raw = [[1.0] * n for n in (1, 2, 3, 6, 36)]
    elif ptype is T.BOOL_ARRAY:
        raw = [[True] * n for n in (1, 3, 6)]
    elif ptype is T.INTEGER_ARRAY:
        raw = [[1] * n for n in (1, 3)]
    else:
        raw = []
    out = [ParameterValue.from_python(r) for r in raw if ParameterValue.from_python(r) != current]
    return out


def _passes(name: str, value: ParameterValue, desc: ParameterDescriptor) -> bool:
    try:
        validate(name, value, desc)
    except ParamddsError:
        return False
    return True


def _fill(entries: list[SpecEntry]) -> dict[str, object]:
    """Values for required entries and for defaults their own validators refuse."""
    fill: dict[str, object] = {}
    for e in entries:
        if e.required or not _passes(e.name, e.default, e.descriptor):
            tries = _candidates(e.descriptor.type, e.default)
            good = next(v for v in tries if _passes(e.name, v, e.descriptor))
            value = good.value
            fill[e.name] = list(value) if isinstance(value, tuple) else value
    return fill


def _set_valid_and_invalid(table: ParameterTable) -> None:
    """A writable parameter takes a valid new value; a wrong type and a validator breach are refused."""
    writable = [(n, v, d) for n, v, d in table.snapshot() if not d.read_only and not d.dynamic_typing]
    assert writable, "no writable parameter"
    done_valid = False
    for name, value, desc in writable:
        good = next((c for c in _candidates(desc.type, value) if _passes(name, c, desc)), None)
        if good is None:
            continue
        outcome = table.set([Parameter(name, good)])
        assert outcome.results[0].successful, outcome.results[0].reason
        assert table.get(name) == good
        done_valid = True
        wrong = ParameterValue.from_python("not a number" if desc.type is not T.STRING else 5)
        before = table.revision
        refused = table.set([Parameter(name, wrong)]).results[0]
        assert not refused.successful and refused.code.value == "TYPE_MISMATCH"
        assert table.get(name) == good and table.revision == before
        break
    assert done_valid


@pytest.mark.parametrize(("file", "node"), [(f, n) for f, nodes in PARAM_FILES.items() for n in nodes])
def test_parameter_file_loads_describes_and_sets(tmp_path: Path, file: str, node: str) -> None:
    path = tmp_path / file
    path.write_text(_text(file), encoding="utf-8")
    loaded = load_ros_file_full(path, node)
    assert loaded, f"{file} gives {node} no parameter"
    table = ParameterTable(node)
    table.declare_from(loaded)
    for name, value, _ in loaded:
        desc = table.describe_one(name)
        assert desc.type is value.type and desc.name == name
    _set_valid_and_invalid(table)


def test_known_values_of_the_parameter_files(tmp_path: Path) -> None:
    # A few values a user relies on, typed as rcl types them.
    ouster = tmp_path / "driver.yaml"
    ouster.write_text(_text("driver_params.yaml"), encoding="utf-8")
    values = load_ros_params(ouster, "ouster/os_driver")
    assert any(v == ParameterValue(T.STRING, "OFF") for v in values.values())  # 'OFF' quoted: a string
    multi = tmp_path / "multi.yaml"
    multi.write_text(_text("multi_controller_manager_rrbot_generic_controllers.yaml"), encoding="utf-8")
    jtc = load_ros_params(multi, "rrbot_1/position_trajectory_controller")
    assert jtc["joints"] == ParameterValue(T.STRING_ARRAY, ("rrbot_1_joint1", "rrbot_1_joint2"))
    assert jtc["state_publish_rate"] == ParameterValue(T.DOUBLE, 200.0)


@pytest.mark.parametrize("spec_file", list(SPECS))
def test_spec_loads_describes_and_sets(
    tmp_path: Path, spec_file: str, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        spec = load_spec(REALWORLD / spec_file)
    assert isinstance(spec, Spec) and len(spec) > 10
    companion = SPECS[spec_file]
    if companion is not None:
        file, node = companion
        params = tmp_path / file
        params.write_text(_text(file), encoding="utf-8")
        overrides = load_ros_params(params, node)
        extra = _fill([e for e in spec if e.name not in overrides])
    else:
        node = "controller"
        extra = _fill(list(spec))
        assert extra, "the fill file gives values"
        overrides = {}
    fill = tmp_path / "fill.yaml"
    fill.write_text(yaml.safe_dump({node: {"ros__parameters": extra}}), encoding="utf-8")
    overrides = {**overrides, **load_ros_params(fill, node)}
    table = ParameterTable(node, overrides=overrides)
    declare_spec(table, spec)
    names = set(table.names())
    assert {e.name for e in spec} <= names
    for entry in spec:
        desc = table.describe_one(entry.name)
        assert desc.type is entry.descriptor.type and desc.description == entry.descriptor.description
    _set_valid_and_invalid(table)
    if spec.unenforced:  # a custom validator nobody registered: a warning naming it, listed in describe
        assert all(name in caplog.text for name in spec.unenforced)
        kinds = {v.kind for _, _, d in table.snapshot() for v in d.validators}
        assert set(spec.unenforced) <= kinds
    for entry in spec:  # additional_constraints is the spec's own text (generate_parameter_library)
        shown = table.describe_one(entry.name).additional_constraints
        assert shown == entry.descriptor.additional_constraints


def test_joint_trajectory_controller_mapped_gains_and_its_validators(tmp_path: Path) -> None:
    spec = load_spec(REALWORLD / "joint_trajectory_controller_parameters.yaml")
    params = tmp_path / "multi.yaml"
    params.write_text(_text("multi_controller_manager_rrbot_generic_controllers.yaml"), encoding="utf-8")
    node = "rrbot_1/position_trajectory_controller"
    table = ParameterTable(node, overrides=load_ros_params(params, node))
    declare_spec(table, spec)
    for joint in ("rrbot_1_joint1", "rrbot_1_joint2"):
        assert table.get(f"gains.{joint}.p") == ParameterValue(T.DOUBLE, 0.0)
        assert table.has(f"constraints.{joint}.goal")
    # a bare argument (gt_eq<>: 0.0) is enforced and fills the descriptor's range
    guarded = [(n, d) for n, _, d in table.snapshot() if any(v.kind == "gt_eq" for v in d.validators)]
    assert guarded
    for name, desc in guarded:
        (bound,) = next(v for v in desc.validators if v.kind == "gt_eq").args
        assert desc.floating_point_range is not None and desc.floating_point_range.from_value == bound.value
        assert not table.set([Parameter(name, ParameterValue(T.DOUBLE, -1.0))]).results[0].successful


def test_diff_drive_custom_validators_are_enforced(tmp_path: Path) -> None:
    spec = load_spec(REALWORLD / "diff_drive_controller_parameter.yaml")
    assert not spec.unenforced  # control_filters::gt_eq_or_nan / lt_eq_or_nan ship with paramdds
    params = tmp_path / "diffbot.yaml"
    params.write_text(_text("diffbot_controllers.yaml"), encoding="utf-8")
    node = "diffbot_base_controller"
    table = ParameterTable(node, overrides=load_ros_params(params, node))
    declare_spec(table, spec)
    kind = "control_filters::gt_eq_or_nan"
    name = next(n for n, _, d in table.snapshot() if any(v.kind == kind for v in d.validators))
    assert table.set([Parameter(name, ParameterValue(T.DOUBLE, math.nan))]).results[0].successful
    assert table.set([Parameter(name, ParameterValue(T.DOUBLE, 0.5))]).results[0].successful
    refused = table.set([Parameter(name, ParameterValue(T.DOUBLE, -0.5))]).results[0]
    assert not refused.successful and "NaN or >=" in refused.reason


def test_strict_spec_refuses_an_unregistered_custom_validator() -> None:
    with pytest.raises(FileFormatError, match=r"command_interface_type_combinations.*not registered"):
        load_spec(REALWORLD / "joint_trajectory_controller_parameters.yaml", strict=True)
    load_spec(REALWORLD / "diff_drive_controller_parameter.yaml", strict=True)  # its validators are known
