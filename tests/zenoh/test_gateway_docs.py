"""docs/zenoh.md as a site runs it: the ``nodes`` table, TLS's extras, the site's DDS file, the loss table.

The page's fleet examples need routers and several machines, so they are marked skip
there; these tests run the same commands on loopback and hold the page to what they print.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from paramdds.zenoh.config import LEASE_MS
from paramdds.zenoh.monitor_rules import SITE_HOLD

from ..conftest import TEST_URI, next_domain_id
from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .conftest import PARAMS, Fleet
from .test_netns import TABLE

pytestmark = pytest.mark.timeout(90)

PAGE = Path(__file__).resolve().parents[2] / "docs" / "zenoh.md"


def _after(command: str) -> list[str]:
    """The lines the page shows after ``$ command`` in a console block, up to the next ``$``."""
    lines = PAGE.read_text(encoding="utf-8").splitlines()
    start = lines.index(f"$ {command}") + 1
    out: list[str] = []
    for line in lines[start:]:
        if line.startswith(("$ ", "```")):
            break
        out.append(line)
    return out


@pytest.mark.slow
def test_the_pages_nodes_table_has_the_columns_the_real_one_has(fleet: Fleet) -> None:
    fleet.server("north", "robot1")
    fleet.gateway("north")
    env = make_dds_env(next_domain_id(), PARAMDDS_ZENOH=fleet.endpoint)
    r = subprocess.run([PARAMDDS, "nodes"], env=env, capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r
    real = r.stdout.splitlines()
    shown = _after("paramdds nodes")
    assert real[0].split() == shown[0].split()  # the same columns (widths follow the values)
    node, online, params, _host, _pid, revision, origin = real[1].split()
    row = shown[0 + 1].split()
    assert (row[0], row[1], row[2], row[6]) == (node, online, params, origin)
    assert revision.isdigit() and row[5].isdigit()


def test_the_page_names_the_extras_mutual_tls_needs() -> None:
    text = PAGE.read_text(encoding="utf-8")
    assert "pip install -e '.[zenoh,secure]'" in text


@pytest.mark.slow
def test_the_pages_site_dds_file_keeps_a_site_on_its_interface(tmp_path: Path) -> None:
    """The page's Cyclone file with ``lo`` for its LAN interface: a server and ``nodes`` meet on it."""
    shown = "\n".join(_after("cat site-dds.xml"))
    assert re.search(r'<NetworkInterface name="\w+"/>', shown), shown
    site_file = tmp_path / "site-dds.xml"
    site_file.write_text(re.sub(r'(?<=<NetworkInterface name=")\w+', "lo", shown), encoding="utf-8")
    env = make_dds_env(next_domain_id(), CYCLONEDDS_URI=f"file://{site_file},{TEST_URI}")
    del env["PARAMDDS_LOCALHOST"]  # the file alone says where DDS goes
    server = Proc([PARAMDDS, "server", "-p", PARAMS, "-n", "robot1"], env)
    try:
        server.wait_for("[SERVER] Serving node robot1", 20)
        r = subprocess.run([PARAMDDS, "nodes"], env=env, capture_output=True, text=True, timeout=30)
        assert r.returncode == 0 and "robot1" in r.stdout, r
    finally:
        server.stop()


def _minutes(window: str) -> float:
    """``10 min`` -> 10, ``90 s`` -> 1.5."""
    number, unit = window.split()
    return float(number) / (60 if unit == "s" else 1)


def test_the_pages_loss_table_is_the_measurement_at_the_lease_and_hold_paramdds_sets() -> None:
    """The table under "Presence under loss" has the columns the measurement prints, and rows
    of at least 10 minutes at 10, 30 and 50 % loss for the lease and the hold paramdds sets."""
    lines = PAGE.read_text(encoding="utf-8").splitlines()
    assert TABLE in lines, "the page's loss table lacks the measurement's columns"
    rows = []
    for line in lines[lines.index(TABLE) + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    columns = [cell.strip() for cell in TABLE.strip("|").split("|")]
    lease, hold, window = (columns.index(c) for c in ("lease", "hold", "false `site_offline` (3 sites)"))
    ours = [row for row in rows if row[lease] == f"{LEASE_MS / 1000:g} s" and row[hold] == f"{SITE_HOLD:g} s"]
    long_enough = {row[0] for row in ours if _minutes(row[window].split(" in ")[1]) >= 10}
    assert long_enough >= {"10 %", "30 %", "50 %"}, rows
