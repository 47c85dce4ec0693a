"""``paramdds dump`` writes a file ROS 2 loads: every node of every real parameter file,
loaded by us, dumped as the dump verb writes it, is read by rcl's own C parser (as a ROS 2
process reads ``--params-file``), by ``rclpy.parameter.parameter_dict_from_yaml_file`` and
by PyYAML (what launch's RewrittenYaml uses) to the same names, types and values (rclpy's
loader retypes some values whatever the file says, see :func:`_rclpy_retypes`; a
subnormal double is a string to rcl, which no form of it avoids)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.values import ParameterType, ParameterValue
from paramdds.formats.dump import dump_ros_params
from paramdds.formats.ros import load_ros_text_full

from . import rcl_yaml as ry
from . import ros_oracle as ro
from .test_realworld import REALWORLD

T = ParameterType
REAL_FILES = sorted(
    p for p in REALWORLD.glob("*.yaml") if "ros__parameters" in p.read_text(encoding="utf-8")
)


@pytest.fixture(scope="module")
def ros_context() -> Iterator[Any]:
    missing = ro.ros_missing()
    if missing is not None:
        pytest.skip(missing)
    with ro.ros_session() as context:
        yield context


def _flat(tree: Any, prefix: str = "") -> dict[str, Any]:
    """PyYAML's nested maps as dotted names (a dotted key is one name already)."""
    if not isinstance(tree, dict):
        return {prefix: tree}
    out: dict[str, Any] = {}
    for k, v in tree.items():
        out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def _pyyaml_type(v: Any) -> ParameterType:
    if isinstance(v, list):
        kinds = {_pyyaml_type(x) for x in v}
        return {T.BOOL: T.BOOL_ARRAY, T.INTEGER: T.INTEGER_ARRAY, T.DOUBLE: T.DOUBLE_ARRAY}.get(
            kinds.pop() if len(kinds) == 1 else T.STRING, T.STRING_ARRAY
        )
    return {bool: T.BOOL, int: T.INTEGER, float: T.DOUBLE}.get(type(v), T.STRING)


def _subnormal(v: ParameterValue) -> bool:
    values = v.value if isinstance(v.value, tuple) else (v.value,)
    return v.type in (T.DOUBLE, T.DOUBLE_ARRAY) and any(
        isinstance(x, float) and x != 0.0 and abs(x) < 2.2250738585072014e-308 for x in values
    )


def _rclpy_retypes(v: ParameterValue) -> bool:
    """rclpy's loader turns each value PyYAML read into text (``str``) and guesses its type
    again with PyYAML, whatever the file says: a string PyYAML reads as another scalar
    ("OFF", "1.5") and a double whose ``str`` has an exponent without a "." (``1e-10``)
    come out strings."""
    values = v.value if isinstance(v.value, tuple) else (v.value,)
    return v.type is T.STRING or any(isinstance(x, float) and "e" in str(x) for x in values)


@pytest.mark.parametrize("path", REAL_FILES, ids=[p.name for p in REAL_FILES])
def test_a_dump_of_every_node_of_a_real_file_is_read_by_rcl_and_pyyaml_as_dumped(
    ros_context: Any, path: Path, tmp_path: Path
) -> None:
    import yaml
    from rclpy.parameter import parameter_dict_from_yaml_file, parameter_value_to_python

    text = path.read_text(encoding="utf-8")
    checked = 0
    for fqn in ry.node_names(text):
        node_id = fqn.lstrip("/")
        loaded = load_ros_text_full(text, node_id, source=path.name)
        ours = {name: value for name, value, _ in loaded}
        if not ours:
            continue
        dumped = dump_ros_params(node_id, loaded)  # what `paramdds dump` writes by default
        file = tmp_path / "dump.yaml"
        file.write_text(dumped, encoding="utf-8")
        status, got = ry.rcl_load(file, (fqn,))[fqn]
        assert status == "ok", f"rcl refused the dump of {fqn}:\n{dumped}"
        want = {n: (v.type.label, v.value) for n, v in ours.items() if not _subnormal(v)}
        assert {n: got[n] for n in want} == want, fqn
        rclpy_dict = parameter_dict_from_yaml_file(str(file), target_nodes=[fqn])
        (tree,) = yaml.safe_load(dumped).values()
        pyyaml = _flat(tree["ros__parameters"])
        for name, value in ours.items():
            assert _pyyaml_type(pyyaml[name]) is value.type or not value.value, (fqn, name, pyyaml[name])
            msg = rclpy_dict[name].value
            if value.value and not _rclpy_retypes(value):
                assert msg.type == int(value.type), (fqn, name, msg)
                if value.type is T.DOUBLE and not math.isnan(value.value):  # type: ignore[arg-type]
                    assert parameter_value_to_python(msg) == value.value
        checked += 1
    assert checked > 0, f"{path.name} configures no node"
