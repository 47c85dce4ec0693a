"""What the recorder tests share: a real `paramdds record` process, `paramdds set`, MCAP read back."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env

PARAMS = """\
parameters:
  - name: "robot.max_velocity"
    type: "double"
    value: 1.5
  - name: "robot.name"
    type: "string"
    value: "my_robot"
  - name: "robot.enabled"
    type: "bool"
    value: true
  - name: "robot.wheel_count"
    type: "integer"
    value: 4
"""
NAMES = ("robot.max_velocity", "robot.name", "robot.enabled", "robot.wheel_count")


def start_recorder(domain: int, path: Path, *args: str) -> Proc:
    """``paramdds record -o PATH ARGS`` on ``domain``, returned once it printed its ready line."""
    proc = Proc([PARAMDDS, "record", "-o", str(path), *args], make_dds_env(domain))
    proc.wait_for("[RECORD] Recording", 30)
    return proc


def cli(domain: int, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PARAMDDS, *args], env=make_dds_env(domain), capture_output=True, text=True, timeout=60
    )


def set_as(domain: int, who: str, node: str, *assignments: str) -> None:
    done = cli(domain, "set", node, *assignments, "--as", who)
    assert done.returncode == 0, done.stderr


def messages(path: Path) -> list[tuple[str, int, dict[str, Any]]]:
    """Every message of a finished recording, in file order: (topic, log time, body)."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        reader = make_reader(f)
        return [
            (channel.topic, m.log_time, json.loads(m.data))
            for _, channel, m in reader.iter_messages(log_time_order=False)
        ]


def stream_messages(path: Path) -> tuple[list[tuple[str, int, dict[str, Any]]], Exception | None]:
    """The messages of a recording read record by record, up to a torn tail; and the error
    that ended the read there (None: the file was whole)."""
    from mcap.records import Channel, Message
    from mcap.stream_reader import StreamReader

    out: list[tuple[str, int, dict[str, Any]]] = []
    topics: dict[int, str] = {}
    with path.open("rb") as f:
        try:
            for record in StreamReader(f, skip_magic=False).records:
                if isinstance(record, Channel):
                    topics[record.id] = record.topic
                elif isinstance(record, Message):
                    out.append((topics[record.channel_id], record.log_time, json.loads(record.data)))
        except Exception as exc:  # the reader's error at the tear
            return out, exc
    return out, None
