"""The monitor's DDS feed: one reader on ``ParameterEvents`` watches every node in the system.

Each batch of samples the reader takes is applied to the monitor's book in one update,
by the rules of :mod:`.monitor_rules`. ``synced`` is emitted once, when every node seen
holds as many parameters as its presence announces (or is offline) and no sample has
arrived for :data:`QUIET` seconds.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from functools import partial
from typing import Any

from cyclonedds.core import Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Qos

from ..core.monitor_events import NodeState
from ..core.state_book import StateBook
from .dispatch import Dispatcher
from .monitor_rules import apply_sample
from .participant import poll_peers
from .qos import QosProfiles
from .topics import make_topic
from .transport import transport_of
from .wire import types as wire
from .wire.state import StateKey, StateSample, decode_key, decode_state

QUIET = 0.1  # seconds without new samples before the initial state counts as received


class DdsStateFeed:
    """A :class:`~paramdds.core.state_book.StateFeed` from one DDS reader of
    ``ParameterEvents`` on ``participant``, with the ``qos`` profiles (default: the packaged ones)."""

    def __init__(self, participant: DomainParticipant, qos: QosProfiles | None = None) -> None:
        self._participant = participant
        self._qos = qos
        self._book: StateBook | None = None
        self._dispatcher: Dispatcher | None = None
        self._last_sample = time.monotonic()

    def start(self, book: StateBook) -> None:
        self._book = book
        participant = self._participant
        qos = self._qos or QosProfiles.load()
        self._last_sample = time.monotonic()
        # no topic filter (it deadlocks against take under load): apply_sample skips other nodes
        topic = make_topic(participant, "ParameterEvents", wire.ParameterEvent)
        # its tick looks into peers whose type or QoS does not match (see .peers)
        self._dispatcher = Dispatcher(
            participant, "paramdds-monitor", tick=partial(poll_peers, participant), period=1.0
        )
        # depth 4, not 1: a late joiner must see the presence samples of every writer of one
        # node (two processes hosting one node id), not only the last one delivered
        reader_qos = qos.reader("ParameterEvents") + Qos(Policy.History.KeepLast(4))
        transport = transport_of(participant)  # secure: the identity's node partitions, checked per sample
        reader = transport.reader(topic, reader_qos)
        self._dispatcher.add_raw(reader, _decode, transport.guard_raw(reader, self._on_samples))
        self._dispatcher.start()
        threading.Thread(target=self._watch_sync, args=(book,), name="paramdds-sync", daemon=True).start()

    def close(self) -> None:
        if self._dispatcher is not None:
            self._dispatcher.close()

    # -- samples → state and events -------------------------------------------------------

    def _on_samples(self, samples: Sequence[tuple[StateSample | StateKey, Any]]) -> None:
        book = self._book
        assert book is not None  # samples come only once started
        with book.update() as change:
            self._last_sample = time.monotonic()
            for s, info in samples:
                apply_sample(book, change, s, info)

    def _watch_sync(self, book: StateBook) -> None:
        """Mark ``book`` synced once every node seen is complete (or offline) and no sample
        has arrived for :data:`QUIET` seconds."""

        def settled(states: dict[str, NodeState]) -> bool:
            quiet = time.monotonic() - self._last_sample >= QUIET
            return quiet and all(s.complete or not s.online for s in states.values())

        while not book.closed:
            quiet_for = time.monotonic() - self._last_sample
            if book.wait_until(settled, max(0.005, QUIET - quiet_for)):
                book.mark_synced()
                return


def _decode(data: bytes, info: Any) -> StateSample | StateKey:
    return decode_state(data) if info.valid_data else decode_key(data)
