"""``server --persist``: acknowledged changes survive a kill; damaged files refuse the start."""

from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest

from paramdds.core.values import ParameterValue
from paramdds.formats.files import dump_text, parse_ros_text
from paramdds.persist import HEADER, TRAILER_PREFIX, PersistStore, frame

from ._support import next_domain, run_cli, start_server


def _persisted(state: Path) -> tuple[dict[str, ParameterValue], list[str]]:
    """What a restart would load for robot1 (snapshot + journal), read without the lock."""
    store = PersistStore(state, dumper=lambda s: dump_text(s, with_descriptors=True), parser=parse_ros_text)
    return {name: value for name, value, _ in store.read("robot1")}, store.deleted("robot1")


@pytest.mark.slow
def test_a_restart_restores_every_acknowledged_change(params_file: Path, tmp_path: Path) -> None:
    domain = next_domain()
    state = tmp_path / "state.yaml"
    args = ("-n", "robot1", "-p", str(params_file), "--persist", str(state))
    server = start_server(domain, *args)
    try:
        assert state.read_text().startswith(HEADER)  # created at start
        out = run_cli(domain, "set", "robot1", "robot.max_velocity=3.25", "sensor.frame_ids=[a, b, c]")
        assert out.returncode == 0, out.stderr
    finally:
        server.stop(signal.SIGKILL)  # no graceful anything: the reply came after the write
    assert state.read_text().splitlines()[-1].startswith(TRAILER_PREFIX)
    values, _ = _persisted(state)  # the snapshot, and the journal appended since
    assert values["robot.max_velocity"].value == 3.25
    server = start_server(domain, *args)
    try:
        got = run_cli(
            domain, "get", "robot1", "robot.max_velocity", "sensor.frame_ids", "robot.name", "-o", "json"
        )
        assert json.loads(got.stdout) == {
            "robot.max_velocity": 3.25,
            "sensor.frame_ids": ["a", "b", "c"],
            "robot.name": "my_robot",
        }
    finally:
        assert server.stop() == 0


@pytest.fixture(scope="module")
def valid_state(params_file: Path, tmp_path_factory: pytest.TempPathFactory) -> str:
    """The text of a persistence file written by a real server (made once per module)."""
    state = tmp_path_factory.mktemp("persist") / "state.yaml"
    server = start_server(next_domain(), "-n", "robot1", "-p", str(params_file), "--persist", str(state))
    server.stop()
    return state.read_text()


BAD = "max_velocity: fast"


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (lambda text: text[: len(text) // 2], "truncated"),
        (lambda text: frame("robot1: [unclosed\n"), "YAML"),  # not YAML
        (lambda text: text.replace("robot.max_velocity", "x").replace("1.5", '"fast"'), "checksum"),
        (lambda text: frame(f"robot1:\n  ros__parameters:\n    robot:\n      {BAD}\n"), "max_velocity"),
        (lambda text: "robot1:\n  ros__parameters:\n    robot:\n      max_velocity: 2.0\n", "-p"),  # not ours
        (lambda text: "", "empty"),
    ],
    ids=["truncated", "not-yaml", "edited", "wrong-type", "hand-written", "empty"],
)
def test_a_damaged_file_refuses_the_start_and_is_left_untouched(
    params_file: Path, tmp_path: Path, valid_state: str, damage: object, message: str
) -> None:
    domain = next_domain()
    state = tmp_path / "state.yaml"
    state.write_text(damage(valid_state))  # type: ignore[operator]
    before = state.read_bytes()
    out = run_cli(domain, "server", "-n", "robot1", "-p", str(params_file), "--persist", str(state))
    assert out.returncode == 2
    assert str(state) in out.stderr and message in out.stderr
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert state.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.slow
def test_a_parameter_deleted_at_runtime_stays_deleted_after_a_restart(tmp_path: Path) -> None:
    params = tmp_path / "params.yaml"
    params.write_text(
        "robot1:\n  ros__parameters:\n    keep: 1\n    scratch:\n      value: 5\n"
        "  paramdds__descriptors:\n    scratch.value:\n      type: integer\n      dynamic_typing: true\n"
    )
    domain = next_domain()
    state = tmp_path / "state.yaml"
    args = ("-n", "robot1", "-p", str(params), "--persist", str(state), "--allow-undeclared")

    server = start_server(domain, *args)
    try:
        out = run_cli(domain, "delete", "robot1", "scratch.value")
        assert out.returncode == 0, out.stderr
    finally:
        server.stop(signal.SIGKILL)
    assert _persisted(state)[1] == ["scratch.value"]

    server = start_server(domain, *args)  # the params file still declares it
    try:
        assert json.loads(run_cli(domain, "list", "robot1", "-o", "json").stdout) == ["keep"]
        out = run_cli(domain, "set", "robot1", "scratch.value=7")  # declared again at runtime
        assert out.returncode == 0, out.stderr
    finally:
        server.stop(signal.SIGKILL)
    assert _persisted(state)[1] == []
    # the next start compacts: the snapshot alone holds the deletion record, then not

    server = start_server(domain, *args)
    try:
        got = run_cli(domain, "get", "robot1", "scratch.value", "-o", "json")
        assert json.loads(got.stdout) == {"scratch.value": 7}
    finally:
        assert server.stop() == 0
