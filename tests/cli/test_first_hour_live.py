"""What a newcomer meets in the first hour on the command line, against real nodes on loopback."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from ._support import ROOT, Proc, next_domain, run_cli, start_server

SPEC = str(ROOT / "examples" / "robot_spec.yaml")
PARAMS = str(ROOT / "examples" / "params.yaml")


@pytest.fixture(scope="module")
def robot1() -> Iterator[tuple[int, Proc]]:
    """A node as the README starts it: the spec's descriptors, the values of params.yaml."""
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "--spec", SPEC, "-p", PARAMS)
    yield domain, server
    server.stop()


def test_a_word_read_as_a_bool_refused_by_a_string_parameter_says_how_to_quote_it(
    robot1: tuple[int, Proc],
) -> None:
    domain, _ = robot1
    out = run_cli(domain, "set", "robot1", "robot.name=yes")
    assert out.returncode == 1
    hint = "'yes' is read as a bool; quote it to send the string: robot.name='\"yes\"'"
    assert out.stdout.splitlines()[0] == (
        f"robot.name: FAILED: Parameter 'robot.name' expects a string but got bool true; {hint}"
    )
    assert out.stderr.rstrip().endswith(hint)
    out = run_cli(domain, "set", "robot1", "robot.name", "ON")  # ros2 param set's form
    assert "quote it to send the string: robot.name='\"ON\"'" in out.stdout
    out = run_cli(domain, "set", "robot1", 'robot.name="yes"')
    assert (out.returncode, out.stdout.splitlines()[0]) == (0, "robot.name: ok")
    # a refusal that quoting would not cure has no hint
    out = run_cli(domain, "set", "robot1", "robot.enabled=fast", "robot.max_velocity=true")
    assert out.returncode == 1 and "quote it" not in out.stdout + out.stderr


def test_watchers_see_a_node_loaded_from_a_ros_2_file_at_revision_1(domain: int) -> None:
    server = start_server(domain, "-n", "robot1", "-p", str(ROOT / "examples" / "robot_params.yaml"))
    watch = Proc(domain, ["watch", "robot1"])
    try:
        watch.wait_for("synced")
        added = [line for line in watch.lines if line.startswith("added ")]
        assert len(added) == 9 and all(line.endswith("  (rev 1)") for line in added), added
    finally:
        watch.stop()
        server.stop()


@pytest.mark.slow  # four servers and eight commands: 6-7 s
def test_list_and_dump_without_a_node_cover_every_node(domain: int, tmp_path: Path) -> None:
    robot_params = str(ROOT / "examples" / "robot_params.yaml")
    servers = [
        start_server(domain, "-n", "robot1", "-n", "fleet/a", "-p", robot_params),
        start_server(domain, "-n", "robot2", "--spec", SPEC, "-p", PARAMS),
    ]
    try:
        out = run_cli(domain, "list", "--prefix", "sensor")
        assert (out.returncode, out.stderr) == (0, "")
        assert out.stdout.splitlines() == [
            "fleet/a:",
            "robot1:",
            "  sensor.frequencies",
            "  sensor.topics",
            "robot2:",
            "  sensor.frequencies",
            "  sensor.topics",
        ]
        out = run_cli(domain, "list", "--depth", "1", "-o", "json")
        top = {"fleet/a": ["use_sim_time"], "robot1": ["use_sim_time"], "robot2": []}
        assert json.loads(out.stdout) == top
        # one file, every node, as `dump` of each node named in order writes it
        for extra in ([], ["--descriptors"]):
            every = run_cli(domain, "dump", *extra)
            named = run_cli(domain, "dump", "fleet/a", "robot1", "robot2", *extra)
            assert (every.returncode, every.stderr) == (0, "")
            assert every.stdout == named.stdout and every.stdout.startswith("/fleet/a:\n")
        (tmp_path / "all.yaml").write_text(every.stdout)
    finally:
        for server in servers:
            server.stop()
    # and a server reads it back, each node its own section
    again = next_domain()
    nodes = ("-n", "robot1", "-n", "fleet/a", "-n", "robot2")
    server = start_server(again, *nodes, "-p", str(tmp_path / "all.yaml"))
    try:
        assert run_cli(again, "dump", "--descriptors").stdout == every.stdout
    finally:
        server.stop()
    assert run_cli(again, "dump", "--timeout", "1").returncode == 3
