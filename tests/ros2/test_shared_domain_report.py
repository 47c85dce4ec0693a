"""What a failed shared-domain start says about a bridge that crashed (faulthandler's report).

The report is made by the shared-domain harness (tests/support/ros2_shared.py) that
test_shared_domain.py uses; it needs no ROS 2.
"""

from __future__ import annotations

from tests.support.ros2_shared import CRASH_CHARS, crash_report

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
