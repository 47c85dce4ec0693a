"""What a newcomer meets in the first hour on the command line, without DDS: hints, checks,
how ranges read."""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
from pathlib import Path

import pytest

from paramdds.exits import UsageError

from ._support import PARAMDDS, ROOT


def test_the_web_extras_hint_is_the_command_docs_web_md_gives(monkeypatch: pytest.MonkeyPatch) -> None:
    from paramdds.cli._extras import PACKAGES
    from paramdds.cli.verbs import web

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name in PACKAGES["web"] else real(name, *a)
    )
    with pytest.raises(UsageError) as caught:
        web.run(argparse.Namespace(port=None, bind="127.0.0.1:8800"))
    message = str(caught.value)
    command = message.rpartition("): ")[2].partition(" in ")[0]
    assert command.startswith("pip install ")
    assert f"{command}       # Starlette + uvicorn" in (ROOT / "docs" / "web.md").read_text()


def check(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([PARAMDDS, "check", *args], capture_output=True, text=True, cwd=ROOT, timeout=60)


def test_check_reads_a_parameter_list_as_server_p_does(tmp_path: Path) -> None:
    out = check("examples/params.yaml", "--spec", "examples/robot_spec.yaml")
    assert (out.returncode, out.stdout, out.stderr) == (0, "examples/params.yaml: ok\n", "")
    schema = subprocess.run(
        [PARAMDDS, "schema", "--spec", "examples/robot_spec.yaml"], capture_output=True, text=True, cwd=ROOT
    )
    (tmp_path / "robot.schema.json").write_text(schema.stdout)
    out = check("examples/params.yaml", "--schema", str(tmp_path / "robot.schema.json"))
    assert (out.returncode, out.stdout) == (0, "examples/params.yaml: ok\n")
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "parameters:\n"
        "  - {name: robot.max_velocity, type: double, value: 7.5}\n"
        "  - {name: robot.colour, type: string, value: red}\n"
        "  - {name: sensor.frequencies, type: double_array, value: []}\n"
    )
    out = check(str(bad), "--spec", "examples/robot_spec.yaml")
    assert out.returncode == 1
    assert out.stdout.splitlines() == [  # the list's typed empty list stays a double_array
        f"{bad}: /**: robot.colour: not declared by the spec",
        f"{bad}: /**: robot.max_velocity: Parameter 'robot.max_velocity' with value 7.5 must be within "
        "[0.0, 5.0]",
        f"{bad}: /**: sensor.frequencies: Parameter 'sensor.frequencies' with value [] must have a size "
        "greater than 0 (it has 0)",
        f"{bad}: robot.name: required by the spec (no default) and given by no section",
    ]
    out = check(str(bad), "--schema", str(tmp_path / "robot.schema.json"))
    assert out.returncode == 1
    greater = f"{bad}: /**: robot.max_velocity: 7.5 is greater than the maximum of 5.0"
    assert greater in out.stdout.splitlines()


def test_a_check_finding_never_prints_placeholder_dashes(tmp_path: Path) -> None:
    neither = tmp_path / "neither.yaml"
    neither.write_text("robot1:\n  speed: 1.0\n")
    out = check(str(neither), "--spec", "examples/robot_spec.yaml")
    assert out.returncode == 1
    assert out.stdout == (
        f"{neither}: no 'ros__parameters' section (neither a ROS 2 parameter file nor a 'parameters:' list)\n"
    )
    cruise = "examples/autoware/schema/cruise.schema.json"
    assert "-: -:" not in check(str(neither), "--schema", cruise).stdout


@pytest.mark.parametrize(
    ("key", "shape", "shown"),
    [
        ("floating_point_range", (0.0, 5.0, 0.0), "[0.0, 5.0]"),
        ("floating_point_range", (1.0, 1.7976931348623157e308, 0.0), "≥ 1.0"),
        ("floating_point_range", ("-inf", 2.5, 0.0), "≤ 2.5"),
        ("floating_point_range", (0.0, "inf", 0.5), "≥ 0.0 step 0.5"),
        ("integer_range", (10, 1000, 10), "[10, 1000] step 10"),
        ("integer_range", (1, 2**63 - 1, 1), "≥ 1 step 1"),
        ("integer_range", (-(2**63), 0, 0), "≤ 0"),
    ],
)
def test_describe_shows_a_range_as_a_person_reads_it(
    key: str, shape: tuple[object, object, object], shown: str
) -> None:
    from paramdds.cli._output import describe_table

    r = dict(zip(("from_value", "to_value", "step"), shape, strict=True))
    table = describe_table({"x": {"type": "double", "read_only": False, key: r}})
    assert table.splitlines()[-1] == f"  {key}: {shown}"


def test_a_range_that_bounds_nothing_is_not_shown() -> None:
    from paramdds.cli._output import describe_table

    r = {"from_value": "-inf", "to_value": 1.7976931348623157e308, "step": 0.0}
    assert describe_table({"x": {"type": "double", "floating_point_range": r}}) == 'x:\n  type: "double"'


def test_a_node_the_files_declare_starts_at_revision_1_whatever_their_number(tmp_path: Path) -> None:
    from paramdds.errors import FileFormatError
    from paramdds.server_process import ServerOptions, prepare

    robot_params = str(ROOT / "examples" / "robot_params.yaml")
    for sim_time in (False, True):
        options = ServerOptions(["robot1", "fleet/a"], [robot_params], use_sim_time=sim_time)
        tables, _, _ = prepare(options)
        shown = {node: (t.revision, len(t)) for node, t in tables.items()}
        assert shown == {"robot1": (1, 9), "fleet/a": (1, 2)}
    spec = str(ROOT / "examples" / "robot_spec.yaml")
    tables, _, _ = prepare(ServerOptions(["robot1"], [str(ROOT / "examples" / "params.yaml")], spec=spec))
    assert tables["robot1"].revision == 1
    # declared in one commit, a value the node cannot take still names the file that gave it
    good, bad = tmp_path / "good.yaml", tmp_path / "bad.yaml"
    good.write_text("robot1:\n  ros__parameters:\n    a: 1\n")
    bad.write_text("robot1:\n  ros__parameters:\n    big: " + "x" * (4 * 1024 * 1024 + 1) + "\n")
    with pytest.raises(FileFormatError) as caught:
        prepare(ServerOptions(["robot1"], [str(good), str(bad)]))
    assert caught.value.file == str(bad) and "'big'" in str(caught.value)
