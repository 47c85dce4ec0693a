"""Which remembered ``/parameter_events`` writers bring a departed node back (``Mirror.returning``).

A real :class:`~paramdds.ros2.rosside.RosSide` and :class:`~paramdds.ros2.mirror.Mirror`, fed
graphs as the bridge reads them: a node leaves, and its writer is seen under rmw's
``_NODE_NAME_UNKNOWN_``. After a clean stop that writer may linger unnamed (the node list
reached the bridge, the process's goodbye did not): the node is not back. After a stall past
the lease the writer was gone from the graph, or the process was stale as it left: it is.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import pytest

from paramdds.dds.filters import STALE
from paramdds.ros2.mirror import UNKNOWN_NODE, Mirror

from .test_mirror import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.timeout(60)]

FQN = "/returning/node"
GID = bytes(range(1, 17)) + bytes(8)  # a writer GID as rmw gives it (16 bytes of GUID, 8 of padding)


@pytest.fixture
def mirror(ros_env: dict[str, str]) -> Iterator[Mirror]:
    from paramdds.ros2.rosside import RosSide

    ros = RosSide(None, "returning_test")
    m = Mirror(ros, lambda _t: None, lambda _n: None, lambda _n, _names: None, timeout=0.2, resync=0)
    yield m
    m.close()
    ros.close()


def _left(mirror: Mirror, *, stale: bool) -> None:
    """Mirror FQN with writer GID (there when the bridge started: taken at once), then see it go."""
    mirror.update({FQN: frozenset({GID})}, time.monotonic())
    m = mirror.nodes[FQN]
    wait_for(lambda: m.failures, 10, "its read tried (no such node: it fails)")
    m.table.status = STALE if stale else None  # as the bridge's liveness probes left it
    mirror.update({}, time.monotonic())
    assert FQN not in mirror.nodes


def test_a_writer_left_unnamed_by_a_clean_stop_does_not_bring_its_node_back(mirror: Any) -> None:
    _left(mirror, stale=False)
    lingering = {UNKNOWN_NODE: frozenset({GID})}
    assert mirror.returning({}, lingering) == {}
    assert mirror.returning({}, lingering) == {}
    # gone from the graph, then seen again unnamed: its process came back (a stall past the lease)
    assert mirror.returning({}, {}) == {}
    assert mirror.returning({}, lingering) == {FQN: frozenset({GID})}
    # named again, it is in the graph: nothing to bring back
    assert mirror.returning({FQN: ""}, lingering) == {}


def test_a_node_whose_process_was_stale_as_it_left_comes_back_at_once(mirror: Any) -> None:
    _left(mirror, stale=True)
    assert mirror.returning({}, {UNKNOWN_NODE: frozenset({GID})}) == {FQN: frozenset({GID})}
