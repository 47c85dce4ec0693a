"""``watch`` reports changes: after a stall, an offline/online or a restart only what changed,
one ``restarted`` line for a new incarnation, never a revision lower than one shown; a
``deleted`` event carries the delete's revision.

Real servers on loopback, stalled with SIGSTOP/SIGCONT and restarted as an operator would.
"""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest

from ._support import Proc, next_domain, run_cli, start_server


def events(watch: Proc, until: str, settle: float = 1.0) -> list[dict[str, object]]:
    watch.wait_for(until)
    start = len(watch.lines) - 1
    watch.drain(settle)
    return [json.loads(line) for line in watch.lines[start:]]


def no_lower_revision(lines: list[dict[str, object]]) -> None:
    """Within one incarnation (restarted starts a new one) no revision is lower than one shown."""
    shown: dict[object, int] = {}
    for e in lines:
        node = e.get("node")
        if e["event"] == "restarted":
            shown.pop(node, None)
        elif "revision" in e:
            revision = int(str(e["revision"]))
            assert revision >= shown.get(node, 0), lines
            shown[node] = revision


@pytest.mark.slow
def test_after_a_stall_and_a_restart_watch_shows_only_changes(params_file: Path, tmp_path: Path) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "-p", str(params_file))
    watch = Proc(domain, ["watch", "robot1", "-o", "json"])
    try:
        watch.wait_for('"synced"')
        assert run_cli(domain, "set", "robot1", "robot.max_velocity=2.5").returncode == 0
        assert run_cli(domain, "set", "robot1", "robot.enabled=false").returncode == 0
        watch.wait_for("robot.enabled")

        os.kill(server.popen.pid, signal.SIGSTOP)  # past the 1 s liveliness lease: offline
        watch.wait_for('"offline"', timeout=10)
        os.kill(server.popen.pid, signal.SIGCONT)
        after_stall = events(watch, '"online"')
        assert [e["event"] for e in after_stall] == ["online"], after_stall

        server.stop()
        watch.wait_for('"offline"', timeout=10)
        changed = tmp_path / "changed.yaml"
        changed.write_text(params_file.read_text().replace("value: 30", "value: 15"))
        server = start_server(domain, "-n", "robot1", "-p", str(changed))
        after_restart = events(watch, '"restarted"', settle=1.5)
        kinds = [(e["event"], e["name"]) for e in after_restart]
        assert sorted(kinds, key=str) == sorted(
            [
                ("restarted", None),
                ("online", None),
                ("modified", "sensor.rate_hz"),  # 30 → 15 in the new file
                ("modified", "robot.max_velocity"),  # the restart set back 2.5 → 1.5
                ("modified", "robot.enabled"),  # and false → true
            ],
            key=str,
        ), after_restart
    finally:
        server.stop()
        watch.stop(signal.SIGINT)
    no_lower_revision([json.loads(line) for line in watch.lines])


@pytest.mark.slow
def test_a_deleted_event_carries_the_delete_revision(params_file: Path) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "-p", str(params_file), "--allow-undeclared")
    watch = Proc(domain, ["watch", "robot1", "-o", "json"])
    try:
        watch.wait_for('"synced"')
        assert run_cli(domain, "set", "robot1", "scratch=1").returncode == 0
        watch.wait_for('"scratch"')
        reply = run_cli(domain, "delete", "robot1", "scratch", "-o", "json")
        assert reply.returncode == 0, reply.stderr
        deleted = json.loads(watch.wait_for('"deleted"'))
        assert deleted["revision"] == json.loads(reply.stdout)["revision"]
        # a second delete, undeclared parameters allowed: declares it again, without a value
        again = run_cli(domain, "delete", "robot1", "scratch", "-o", "json")
        assert again.returncode == 0, again.stderr
        added = json.loads(watch.wait_for('"scratch"'))
        assert (added["event"], added["type"], added["revision"]) == (
            "added",
            "not_set",
            json.loads(again.stdout)["revision"],
        )
    finally:
        server.stop()
        watch.stop(signal.SIGINT)
