"""A ROS 2 host stopped cleanly (``quit``) takes every node out of the graph while ROS 2 runs.

rclpy 9's ``try_shutdown`` destroys the nodes its context tracks while removing each from the
list it walks, so it destroys every other one; the rest, destroyed after ROS 2 had shut
down, left the graph last, and when that last update and the process's goodbye were lost,
only with the participant's lease (20 s), mirrored online meanwhile. The host destroys its
nodes itself, in the order it made them, before it shuts ROS 2 down. An observer process
(rclpy, a context of its own) samples the graph while the host stops: what it sees of the
host's nodes must always be the later-made ones.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from .conftest import RosHost

pytestmark = [pytest.mark.slow, pytest.mark.timeout(120)]

NODES = [f"/leaving/n{i:02d}" for i in range(12)]

# prints "seen" once every node is in the graph, then, after a line on stdin, the distinct
# sets of the nodes it sees (sampled every 5 ms) until none is left, as one JSON line
OBSERVER = """
import json, sys, time
import rclpy
from rclpy.context import Context
ctx = Context()
rclpy.init(context=ctx)
node = rclpy.create_node("leaving_observer", context=ctx, start_parameter_services=False)
want = int(sys.argv[1])
def names():
    return sorted(n for n, ns in node.get_node_names_and_namespaces() if ns == "/leaving")
deadline = time.monotonic() + 30
while len(names()) < want and time.monotonic() < deadline:
    time.sleep(0.05)
print("seen", len(names()), flush=True)
sys.stdin.readline()
seen, deadline = [], time.monotonic() + 10
while time.monotonic() < deadline:
    now = names()
    if not seen or seen[-1] != now:
        seen.append(now)
    if not now:
        break
    time.sleep(0.005)
print(json.dumps(seen), flush=True)
node.destroy_node()
rclpy.shutdown(context=ctx)
"""


def test_a_host_that_quits_takes_its_nodes_out_of_the_graph_in_order(ros_env: dict[str, str]) -> None:
    host = RosHost(ros_env, *[a for n in NODES for a in ("--node", n)], "--threads", "1")
    with subprocess.Popen(
        [sys.executable, "-c", OBSERVER, str(len(NODES))],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=ros_env,
    ) as observer:
        try:
            assert observer.stdout is not None and observer.stdin is not None
            assert observer.stdout.readline().split() == ["seen", str(len(NODES))]
            observer.stdin.write("go\n")
            observer.stdin.flush()
            host.close()  # "quit": a clean stop
            assert host.proc.returncode == 0
            seen = json.loads(observer.stdout.readline())
        finally:
            host.close()
            if observer.poll() is None:
                observer.kill()
    names = [n.rpartition("/")[2] for n in NODES]
    assert seen[-1] == [], seen  # every node left, well within the lease
    # nodes leave in the order they were made: each set seen is the later-made nodes
    assert all(s == names[len(names) - len(s) :] for s in seen), seen
