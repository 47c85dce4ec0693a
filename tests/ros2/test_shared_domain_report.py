"""What the shared-domain harness reports: a crashed bridge's stack (faulthandler's report),
its verdict and its table.

The report is made by the shared-domain harness (tests/support/ros2_shared.py) that
test_shared_domain.py uses; it needs no ROS 2.
"""

from __future__ import annotations

import pytest

from tests.support.ros2_shared import CRASH_CHARS, crash_report, ok, spread, table

DUMP = """paramdds: INFO: paramdds.ros2.bridge: the ROS 2 graph has 101 nodes
Fatal Python error: Segmentation fault

Thread 0x0001 (most recent call first):
  File "bridge.py", line 147 in _run

Current thread 0x0002 (most recent call first):
  File "mirror.py", line 2 in _sync
  File "thread.py", line 3 in _worker

Thread 0x0003 (most recent call first):
  File "rosside.py", line 4 in _spin

Extension modules: cyclonedds._clayer (total: 1)
"""


def test_the_crashing_threads_stack_comes_first_then_every_other_thread() -> None:
    report = crash_report(DUMP)
    lines = report.splitlines()
    assert lines[0] == "Fatal Python error: Segmentation fault"
    assert lines[1].startswith("Current thread 0x0002") and "in _sync" in lines[2]
    assert report.index("Thread 0x0001") > report.index("in _worker")
    assert "Thread 0x0003" in report and "Extension modules" in report
    assert "the ROS 2 graph" not in report  # the log before the crash is left out


def test_a_crash_in_a_thread_without_python_keeps_the_dump_as_it_is() -> None:
    # a crash in a Fast DDS thread: faulthandler lists the Python threads, none is current
    dump = DUMP.replace("Current thread 0x0002", "Thread 0x0002")
    assert crash_report(dump) == dump[dump.index("Fatal Python error") :]


def test_no_crash_no_report_and_a_long_dump_is_cut() -> None:
    assert crash_report("paramdds: INFO: all well\n") == ""
    long = "Fatal Python error: Segmentation fault\n\n" + "  File 'x.py', line 1 in f\n" * 5000
    assert len(crash_report(long)) == CRASH_CHARS


def _result(**over: object) -> dict[str, object]:
    result: dict[str, object] = {
        "nodes": 100,
        "hosts": 4,
        "unknown_per_node": 3,
        "type_lookup": "off",
        "starved": {"stops": 12, "seconds": 17.5},
        "starts": 2,
        "dead": [],
        "unmirrored": [],
        "start": spread([2.5, 4.0]),
        "stalls": {
            "5": {**spread([0.4, 0.6]), "noticed": [0, 25]},
            "25": {**spread([1.2, None]), "noticed": [25, 25]},
        },
        "tools": [],
    }
    result.update(over)
    return result


def test_a_run_passes_only_with_no_dead_bridge_and_every_node_mirrored_after_each_start_and_stall() -> None:
    assert ok(_result())
    assert not ok(_result(dead=[{"start": 2, "when": "start", "exit": -11, "report": ""}]))
    assert not ok(_result(unmirrored=[{"start": 1, "when": "stall 25 s", "missing": 20}]))
    assert not ok(_result(start=spread([2.5, None])))


def test_the_table_says_dead_bridges_and_each_stalls_recovery() -> None:
    lines = table(_result(dead=[{"start": 2, "when": "stall 5 s", "exit": -11, "report": ""}])).splitlines()
    assert lines[0].startswith("100 nodes in 4 host processes, 3 publishers of unknown types each")
    assert "starved: 12 stops, 17.5 s" in lines[0]
    assert lines[1] == "bridges dead: 1 of 2" and lines[2] == "  start 2 (stall 5 s): exit -11"
    assert "start to all mirrored: min 2.5 s, median 3.25 s, max 4.0 s" in lines[3]
    assert lines[4] == (
        "stall 5 s: every node mirrored again after 2 of 2 stalls; nodes shown not mirrored during each: "
        "[0, 25]; SIGCONT to all mirrored: min 0.4 s, median 0.5 s, max 0.6 s"
    )
    assert lines[5].startswith("stall 25 s: every node mirrored again after 1 of 2 stalls;")


def test_the_table_says_how_long_the_starved_bridge_ran_of_each_recovery() -> None:
    stalls = {"60": {**spread([2.0, 6.0]), "noticed": [25, 25], "bridge_ran": spread([0.8, 1.1])}}
    line = next(x for x in table(_result(stalls=stalls)).splitlines() if x.startswith("stall 60 s"))
    assert line.endswith(
        "SIGCONT to all mirrored: min 2.0 s, median 4.0 s, max 6.0 s; of which the bridge ran: "
        "min 0.8 s, median 0.95 s, max 1.1 s"
    )


@pytest.mark.slow  # watches a process starved for 6 s
def test_the_starver_counts_the_seconds_its_process_ran() -> None:
    import subprocess
    import sys
    import time

    from tests.support.ros2_shared import STARVE_RUN, STARVE_STOP, Starver

    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        start = time.monotonic()
        starver = Starver(proc.pid, seed=3)
        time.sleep(6.0)
        end = time.monotonic()
        starver.stop()
        ran = starver.ran(start, end)
        # every second of the window is run or stopped; at least one stop in 6 s
        assert starver.stops >= 1
        assert abs(ran + starver.stopped - (end - start)) < 0.1, (ran, starver.stopped)
        assert STARVE_RUN[0] <= starver.ran(start, start + STARVE_RUN[0])  # it runs before its first stop
        assert starver.ran(end, end + 1.0) == 1.0  # not starved any more
        assert STARVE_STOP[0] <= starver.stopped
    finally:
        proc.kill()
        proc.wait()
