"""The pure part of the "dead writer owes nothing" rule (:func:`paramdds.dds.discovery.owed`).

A model: matched writers, each pending (delivered nothing) or delivered, each alive or
not; the watch knows how many are not alive (Cyclone's count) and, of the delivered
ones, which are known alive (an alive instance). The rule must never excuse an alive
pending writer (a slow server is waited for), and must excuse every pending writer
when all of them are dead and every delivered writer is known alive.
"""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from paramdds.dds.discovery import owed

WRITER = st.tuples(st.booleans(), st.booleans(), st.booleans())  # pending, alive, known alive (if delivered)


@given(st.lists(WRITER, max_size=12))
def test_an_alive_pending_writer_is_always_owed(writers: list[tuple[bool, bool, bool]]) -> None:
    pending = [alive for is_pending, alive, _ in writers if is_pending]
    not_alive = sum(1 for _, alive, _ in writers if not alive)
    # a delivered writer is "known alive" only if it is (its instance is alive)
    unsure = sum(1 for is_pending, alive, known in writers if not is_pending and not (alive and known))
    left = owed(len(pending), not_alive, unsure)
    assert left >= sum(pending)  # never fewer owed than the pending writers still alive
    assert 0 <= left <= len(pending)


def test_the_cases_of_the_issue() -> None:
    assert owed(1, 1, 0) == 0  # one server died before delivering, the three others delivered and live
    assert owed(1, 0, 0) == 1  # a slow server, alive: waited for
    assert owed(2, 1, 0) == 1  # a slow one and a dead one: one is still owed, so not settled
    assert owed(1, 1, 1) == 1  # a dead delivered one (or a stalled node) explains the count: wait
    assert owed(3, 3, 0) == 0  # three dead, nothing delivered yet from anyone
    assert owed(0, 3, 0) == 0
