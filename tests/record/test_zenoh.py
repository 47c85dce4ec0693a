"""`paramdds record --zenoh`: a site's nodes recorded from the cloud, as `SITE/NODE`, with their authors."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from ..zenoh.conftest import Fleet
from ._support import messages

pytestmark = [pytest.mark.slow, pytest.mark.timeout(180)]



def test_a_remote_site_is_recorded_with_its_authors(fleet: Fleet, tmp_path: Path) -> None:
    fleet.server("s1", "robot1")
    fleet.gateway("s1")
    path = tmp_path / "fleet.mcap"
    env = make_dds_env(fleet.domain("cloud"))
    rec = Proc([PARAMDDS, "--zenoh", fleet.endpoint, "record", "-o", str(path)], env)
    fleet.procs.append(rec)
    rec.wait_for("[RECORD] Recording 1 node to", 30)
    cli = [PARAMDDS, "--zenoh", fleet.endpoint, "--as", "carol", "set", "s1/robot1", "robot.max_velocity=2.5"]
    done = subprocess.run(cli, env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    time.sleep(1.5)
    assert rec.stop() == 0, rec.stderr_text()
    msgs = messages(path)
    (snap,) = [b for t, _, b in msgs if t == "/paramdds/snapshot"]
    assert snap["node"] == "s1/robot1" and snap["online"] is True
    changes = [
        (b["node"], b["name"], b["new"]["value"], b["who"], b["via"])
        for t, _, b in msgs
        if t == "/paramdds/changes"
    ]
    assert changes == [("s1/robot1", "robot.max_velocity", 2.5, "carol", "zenoh")]
