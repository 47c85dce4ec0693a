"""What a newcomer meets in the first hour on the command line, against real nodes on loopback."""

from __future__ import annotations

from collections.abc import Iterator

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
