"""One thread that waits on a WaitSet and hands each reader's samples to a handler.

Servers, clients and monitors all use it: no polling, no Cyclone listeners (their
callbacks run on Cyclone's receive thread and a listener still attached at exit
can hang the process). ``close()`` wakes the thread through a GuardCondition and
joins it, so shutdown is prompt.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Sequence
from typing import Any

from cyclonedds.core import GuardCondition, InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.util import duration

from .cdr import is_malformed

log = logging.getLogger(__name__)

Handler = Callable[[Sequence[Any]], None]
_TAKE_BATCH = 256


class Dispatcher:
    def __init__(self, participant: Any, name: str) -> None:
        self._participant = participant
        self._waitset = WaitSet(participant)
        self._guard = GuardCondition(participant)
        self._waitset.attach(self._guard)
        self._entries: list[tuple[Any, Any, Handler]] = []
        self._stopping = False
        self._warned: set[str] = set()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def add(self, reader: Any, handler: Handler) -> None:
        """Call ``handler(samples)`` on the dispatch thread whenever ``reader`` has data."""
        condition = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
        self._entries.append((reader, condition, handler))
        self._waitset.attach(condition)

    def start(self) -> None:
        self._thread.start()

    @property
    def thread_ident(self) -> int | None:
        return self._thread.ident

    def close(self) -> None:
        self._stopping = True
        self._guard.set(True)
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)
        for _, condition, _ in self._entries:
            self._waitset.detach(condition)

    def _run(self) -> None:
        forever = duration(infinite=True)
        while not self._stopping:
            self._waitset.wait(forever)
            if self._stopping:
                break
            for reader, _, handler in self._entries:
                self._drain(reader, handler)

    def _drain(self, reader: Any, handler: Handler) -> None:
        while True:
            samples = reader.take(N=_TAKE_BATCH)
            if not samples:
                return
            good = [s for s in samples if not is_malformed(s)]
            if len(good) < len(samples) and reader.topic.name not in self._warned:
                self._warned.add(reader.topic.name)  # a flood of bad samples must not flood the log
                log.warning("%s: dropped an undecodable sample (further ones not logged)", reader.topic.name)
            try:
                if good:
                    handler(good)
            except Exception:  # a bug in one handler must not stop the thread
                log.exception("handler for %s failed", reader.topic.name)
            if len(samples) < _TAKE_BATCH:
                return
