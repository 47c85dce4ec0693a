"""``paramdds server --schema``, ``paramdds check`` and ``paramdds schema`` as a user runs them:
real processes, real Cyclone DDS on loopback, a domain of each test's own; check-jsonschema
(the test extra) is the reference verdict.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from paramdds.formats.schema import load_schema

from ..cli._support import PARAMDDS, run_cli, start_server
from ..core.test_yaml_schema import AUTOWARE, PASSING, REALWORLD, needs_realworld

CHECK_JSONSCHEMA = str(Path(sys.executable).with_name("check-jsonschema"))


def check_jsonschema(schema: Path, *files: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [CHECK_JSONSCHEMA, "--schemafile", str(schema), *map(str, files)],
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.slow
@needs_realworld
@pytest.mark.parametrize(("schema_path", "params"), PASSING, ids=lambda x: x.name)
def test_a_passing_pair_is_served_and_its_exported_schema_validates_its_dump(
    schema_path: Path, params: Path, domain_id: int, tmp_path: Path
) -> None:
    server = start_server(domain_id, "-n", "node1", "--schema", str(schema_path), "-p", str(params))
    try:
        declared = load_schema(schema_path).entries
        got = run_cli(domain_id, "describe", "node1", *[e.name for e in declared], "-o", "json")
        assert got.returncode == 0, got.stderr
        described = json.loads(got.stdout)
        for e in declared:
            d = described[e.name]
            assert d["description"] == e.descriptor.description
            assert d["type"] == e.descriptor.type.label or e.descriptor.dynamic_typing
            assert d["additional_constraints"] == e.descriptor.additional_constraints
        exported = run_cli(domain_id, "schema", "node1")
        dump = run_cli(domain_id, "dump", "node1")
        assert exported.returncode == 0 and dump.returncode == 0, exported.stderr + dump.stderr
        (tmp_path / "node.schema.json").write_text(exported.stdout)
        # a parameter declared without a value dumps as paramdds's own "!not_set", which no
        # other YAML tool reads: such a parameter is absent from the node's state, so from the file
        lines = [line for line in dump.stdout.splitlines() if not line.endswith(": !not_set")]
        (tmp_path / "dump.yaml").write_text("\n".join(lines) + "\n")
        verdict = check_jsonschema(tmp_path / "node.schema.json", tmp_path / "dump.yaml")
        assert verdict.returncode == 0, verdict.stdout + verdict.stderr
    finally:
        server.stop()


@pytest.mark.slow
@needs_realworld
def test_a_set_the_schema_refuses_is_refused_with_its_reason_over_dds(domain_id: int) -> None:
    pkg = AUTOWARE / "autoware_joy_controller"
    server = start_server(
        domain_id,
        "-n",
        "joy",
        "--schema",
        str(pkg / "schema/joy_controller.schema.json"),
        "-p",
        str(pkg / "config/joy_controller_ds4.param.yaml"),
    )
    try:
        got = run_cli(domain_id, "set", "joy", "update_rate=0", "joy_type=G29")
        assert got.returncode == 1
        assert (
            "update_rate: FAILED: schema: update_rate: 0.0 is less than or equal to the minimum of 0"
            in got.stdout
        )
        assert "joy_type: ok" in got.stdout
        got = run_cli(domain_id, "set", "--atomic", "joy", "joy_type=DS4", "accel_sensitivity=2.0")
        assert got.returncode == 1 and "the atomic set failed on 'accel_sensitivity'" in got.stdout
        assert run_cli(domain_id, "get", "joy", "joy_type").stdout == "joy_type = string 'G29'\n"
    finally:
        server.stop()


@needs_realworld
def test_check_autoware_gives_check_jsonschemas_verdicts_in_under_two_seconds() -> None:
    start = time.monotonic()
    got = subprocess.run([PARAMDDS, "check", "--autoware", str(AUTOWARE)], capture_output=True, text=True)
    elapsed = time.monotonic() - start
    assert got.returncode == 1, got.stderr
    lines = got.stdout.splitlines()
    assert sum(line.endswith(": ok") for line in lines) == 17
    assert any(
        "behavior_velocity_planner.param.yaml: /**: behavior_output_path_interval: Additional properties"
        in line
        for line in lines
    )
    assert "adapi_adaptors.schema.json: no config/adapi_adaptors*.param.yaml" in got.stdout
    assert elapsed < 2.0, elapsed


@needs_realworld
def test_check_a_broken_ref_is_exit_2_naming_file_and_ref() -> None:
    pkg = AUTOWARE / "autoware_adapi_adaptors"
    got = subprocess.run(
        [
            PARAMDDS,
            "check",
            str(pkg / "config/initial_pose.param.yaml"),
            "--schema",
            str(pkg / "schema/adapi_adaptors.schema.json"),
        ],
        capture_output=True,
        text=True,
    )
    assert got.returncode == 2
    assert "adapi_adaptors.schema.json" in got.stderr and "initial_pose_particle_covariance" in got.stderr
    assert "Traceback" not in got.stderr


def _schema(leaf: dict[str, object]) -> str:
    params = {"properties": {"a": leaf}}
    return json.dumps({"type": "object", "properties": {"/**": {"properties": {"ros__parameters": params}}}})


def test_server_schema_bad_input_is_exit_2_without_traceback(domain_id: int, tmp_path: Path) -> None:
    bad = tmp_path / "bad.schema.json"
    bad.write_text(_schema({"type": "number", "maximun": 1}))
    got = run_cli(domain_id, "server", "--schema", str(bad))
    assert got.returncode == 2
    assert "bad.schema.json" in got.stderr and "maximun" in got.stderr and "Traceback" not in got.stderr
    params = tmp_path / "p.yaml"
    params.write_text("/**:\n  ros__parameters:\n    a: 5.0\n")
    bad.write_text(_schema({"type": "number", "maximum": 1}))
    got = run_cli(domain_id, "server", "--schema", str(bad), "-p", str(params))
    assert got.returncode == 2 and "break the schema: a: 5.0 is greater than the maximum of 1" in got.stderr


def test_server_lenient_starts_without_the_refused_value(domain_id: int, tmp_path: Path) -> None:
    schema = tmp_path / "s.schema.json"
    schema.write_text(_schema({"type": "number", "default": 0.5, "maximum": 1, "x-note": 1}))
    params = tmp_path / "p.yaml"
    params.write_text("/**:\n  ros__parameters:\n    a: 5.0\n")
    server = start_server(domain_id, "-n", "n1", "--schema", str(schema), "-p", str(params), "--lenient")
    try:
        assert run_cli(domain_id, "get", "n1", "a").stdout == "a = double 0.5\n"
    finally:
        server.stop()
    assert "'a' starts without the file's value" in server.stderr()
    assert "x-note" in server.stderr()


@needs_realworld
def test_check_against_a_spec_with_its_real_configuration(tmp_path: Path) -> None:
    spec = REALWORLD / "diff_drive_controller_parameter.yaml"
    good = subprocess.run(
        [PARAMDDS, "check", str(REALWORLD / "diffbot_controllers.yaml"), "--spec", str(spec)],
        capture_output=True,
        text=True,
    )
    # the file has other controllers' sections too: their names are not the spec's
    assert "diffbot_base_controller: wheel_separation" not in good.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "diffbot_base_controller:\n  ros__parameters:\n    wheel_separation: -1.0\n    left_wheel_names: []\n"
    )
    got = subprocess.run([PARAMDDS, "check", str(bad), "--spec", str(spec)], capture_output=True, text=True)
    assert got.returncode == 1
    assert "diffbot_base_controller: wheel_separation:" in got.stdout
    assert "diffbot_base_controller: left_wheel_names:" in got.stdout


@pytest.mark.slow
@needs_realworld
def test_check_speaks_json_and_schema_derives_from_a_spec_with_mapped_parameters(tmp_path: Path) -> None:
    pkg = AUTOWARE / "behavior_velocity_planner"
    got = subprocess.run(
        [
            PARAMDDS,
            "check",
            "-o",
            "json",
            str(pkg / "config/behavior_velocity_planner.param.yaml"),
            "--schema",
            str(pkg / "schema/behavior_velocity_planner.schema.json"),
        ],
        capture_output=True,
        text=True,
    )
    assert got.returncode == 1
    [report] = json.loads(got.stdout)
    assert report["valid"] is False
    assert report["errors"][0]["section"] == "/**"
    assert report["errors"][0]["path"] == "behavior_output_path_interval"
    spec = REALWORLD / "joint_trajectory_controller_parameters.yaml"
    got = subprocess.run([PARAMDDS, "schema", "--spec", str(spec)], capture_output=True, text=True)
    assert got.returncode == 0, got.stderr
    schema = json.loads(got.stdout)
    import jsonschema

    jsonschema.Draft7Validator.check_schema(schema)
    gains = schema["definitions"]["joint_trajectory_controller_parameters"]["properties"]["gains"]
    assert gains["additionalProperties"]["properties"]["p"]["type"] == "number"  # gains.__map_joints.p
    (tmp_path / "s.json").write_text(got.stdout)
    (tmp_path / "p.yaml").write_text(
        "/**:\n  ros__parameters:\n    joints: [j1]\n    gains:\n      j1: {p: 1.0}\n"
    )
    assert check_jsonschema(tmp_path / "s.json", tmp_path / "p.yaml").returncode == 0
    (tmp_path / "p.yaml").write_text(
        "/**:\n  ros__parameters:\n    joints: [j1]\n    gains:\n      j1: {p: x}\n"
    )
    assert check_jsonschema(tmp_path / "s.json", tmp_path / "p.yaml").returncode == 1
