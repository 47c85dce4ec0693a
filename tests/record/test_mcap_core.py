"""A recording read by the TypeScript reader `@mcap/core`: the messages Python reads, a torn file too.

Two recorders run at once while nodes change: one is stopped with SIGINT (a finished
file), the other killed with ``kill -9`` (a torn one). ``node read_mcap.js`` reads each
with ``McapStreamReader`` (zstd from ``@mcap/support``): the finished file is complete and
its messages are Python's, byte for byte as JSON; the torn one is read up to the tear,
the same messages as Python's ``StreamReader`` reads, every change older than 2 s before
the kill among them.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from ..foxglove.conftest import require_node_packages, run_node
from ..reliability.conftest import start_server
from ._support import PARAMS, messages, set_as, start_recorder, stream_messages

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]


@pytest.fixture
def node_dir() -> Path:
    return require_node_packages()


@pytest.fixture
def robot(domain_id: int, tmp_path: Path) -> Iterator[int]:
    params = tmp_path / "params.yaml"
    params.write_text(PARAMS)
    server = start_server(domain_id, "-n", "robot1", "-p", str(params))
    yield domain_id
    server.stop()


def _node_read(path: Path) -> tuple[list[tuple[str, int, object]], dict[str, object]]:
    events = run_node("read_mcap.js", str(path))
    got = [(e["topic"], int(e["log_time"]), e["data"]) for e in events if e["event"] == "message"]
    (end,) = [e for e in events if e["event"] == "end"]
    return got, end


def test_mcap_core_reads_a_finished_and_a_killed_recording(
    node_dir: Path, robot: int, tmp_path: Path
) -> None:
    domain = robot
    finished, killed = tmp_path / "finished.mcap", tmp_path / "killed.mcap"
    a = start_recorder(domain, finished)
    b = start_recorder(domain, killed)
    made: list[tuple[float, float]] = []
    try:
        for i in range(10):
            set_as(domain, "frank", "robot1", f"robot.max_velocity={30.0 + i}")
            made.append((time.monotonic(), 30.0 + i))
            time.sleep(0.2)
        killed_at = b.kill()
        time.sleep(1.5)
        a.popen.send_signal(signal.SIGINT)  # Ctrl-C finishes the file as SIGTERM does
        assert a.popen.wait(15) == 0, a.stderr_text()
    finally:
        a.stop()
        b.stop()

    python = messages(finished)
    ts, end = _node_read(finished)
    assert end["complete"] is True and end["remaining"] == 0
    assert ts == [(t, log_time, body) for t, log_time, body in python]
    assert [d["new"]["value"] for t, _, d in ts if t == "/paramdds/changes"] == [v for _, v in made]  # type: ignore[index]

    torn, _ = stream_messages(killed)
    ts, end = _node_read(killed)
    assert end["complete"] is False
    assert ts == torn
    older = [v for when, v in made if when < killed_at - 2.0]
    assert older and [d["new"]["value"] for t, _, d in ts if t == "/paramdds/changes"][: len(older)] == older  # type: ignore[index]
