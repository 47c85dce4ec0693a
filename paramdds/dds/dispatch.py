"""One thread that waits on a WaitSet and hands each reader's samples to a handler.

Servers, clients and monitors all use it: no polling, no Cyclone listeners (their
callbacks run on Cyclone's receive thread and a listener still attached at exit
can hang the process). ``close()`` wakes the thread through a GuardCondition and
joins it, so shutdown is prompt.

A reader added with :meth:`Dispatcher.add_raw` skips the binding's decoder: its
samples come as serialized bytes and a ``decode`` function of ours turns each
into what the handler needs (the monitor decodes state samples straight into
core values, see :mod:`.state`). Either way an undecodable sample is dropped
alone, with one warning per topic, and the rest of its batch is handled.

Nothing a peer sends may stop the loop: samples are taken as bytes and decoded by
us (a dispose or unregister whose key does not decode is dropped like any other
undecodable sample), a ``take`` that raises anyway is logged and the loop goes on,
and should the loop itself end by an error it says so in the log. A ``tick``
function given to the constructor runs from the loop at least every ``period``
seconds: the server asserts its liveliness there, so a loop that stops or stalls
stops looking alive.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from cyclonedds.core import (
    GuardCondition,
    InstanceState,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import DomainParticipant
from cyclonedds.internal import InvalidSample
from cyclonedds.util import duration

from ._binding import take_serialized
from .wire.cdr import MalformedSample, is_malformed

log = logging.getLogger(__name__)

T = TypeVar("T")
Handler = Callable[[Sequence[Any]], None]
Take = Callable[[], tuple[list[Any], int]]  # one batch: (good samples, samples taken)
_TAKE_BATCH = 256
SERIALIZED = "_paramdds_serialized"  # attribute of a sample taken by add(): its bytes as received
_ANY = SampleState.Any | ViewState.Any | InstanceState.Any


class Dispatcher:
    def __init__(
        self,
        participant: DomainParticipant,
        name: str,
        *,
        tick: Callable[[], None] | None = None,
        period: float = 0.25,
    ) -> None:
        self._participant = participant
        self._tick = tick
        self._period = period
        self._next_tick = 0.0
        self._waitset = WaitSet(participant)
        self._guard = GuardCondition(participant)
        self._waitset.attach(self._guard)
        self._entries: list[tuple[Take, Any, Handler, str]] = []
        self.readers: list[Any] = []  # in the order added
        self._stopping = False
        self._warned: set[str] = set()
        self._failed_take: set[str] = set()
        self.died: str | None = None  # why the loop ended, if not by close()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def add(self, reader: Any, handler: Handler) -> None:
        """Call ``handler(samples)`` on the dispatch thread whenever ``reader`` has data."""

        data_type = reader.topic.data_type

        def take() -> tuple[list[Any], int]:
            batch = take_serialized(reader, _ANY, _TAKE_BATCH)
            good: list[Any] = []
            for data, info in batch:
                try:  # our wire types never raise (they mark instead); the binding's own may
                    if info.valid_data:
                        sample = data_type.deserialize(data)
                        if is_malformed(sample):
                            continue
                        sample.sample_info = info
                        setattr(sample, SERIALIZED, data)  # the bytes as received (retry checks)
                        good.append(sample)
                    else:  # a dispose or unregister: the binding decodes the key
                        good.append(InvalidSample(data_type.deserialize_key(data), info))
                except Exception:
                    continue  # dropped: taken, but not among the good ones
            return good, len(batch)

        self._add(reader, take, handler)

    def add_raw(
        self,
        reader: Any,
        decode: Callable[[bytes, Any], T],
        handler: Callable[[Sequence[tuple[T, Any]]], None],
    ) -> None:
        """Call ``handler([(decode(data, info), info), …])`` whenever ``reader`` has data.

        ``data`` is the serialized sample, or its serialized key when
        ``info.valid_data`` is false; a sample whose ``decode`` raises
        :class:`~.cdr.MalformedSample` is dropped.
        """

        def take() -> tuple[list[Any], int]:
            batch = take_serialized(reader, _ANY, _TAKE_BATCH)
            good = []
            for data, info in batch:
                try:
                    sample = decode(data, info)
                except MalformedSample:
                    continue  # dropped: taken, but not among the good ones
                good.append((sample, info))
            return good, len(batch)

        self._add(reader, take, handler)

    def _add(self, reader: Any, take: Take, handler: Handler) -> None:
        condition = ReadCondition(reader, _ANY)
        self._entries.append((take, condition, handler, reader.topic.name))
        self.readers.append(reader)
        self._waitset.attach(condition)

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._stopping = True
        self._guard.set(True)
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)
        for _, condition, _, _ in self._entries:
            with contextlib.suppress(Exception):  # a condition whose reader is already gone
                self._waitset.detach(condition)

    def _run(self) -> None:
        try:
            self._loop()
        except BaseException as exc:  # say why, then let the thread end
            self.died = f"{type(exc).__name__}: {exc}"
            log.critical("%s: the dispatch loop ended: %s", self._thread.name, self.died, exc_info=True)

    def _loop(self) -> None:
        timeout = duration(infinite=True) if self._tick is None else int(self._period * 1e9)
        while not self._stopping:
            self._waitset.wait(timeout)
            if self._stopping:
                break
            self._run_tick()
            for take, _, handler, topic in self._entries:
                self._drain(take, handler, topic)

    def _run_tick(self) -> None:
        if self._tick is None:
            return
        now = time.monotonic()
        if now < self._next_tick:
            return
        self._next_tick = now + self._period / 2
        try:
            self._tick()
        except Exception:
            log.exception("%s: tick failed", self._thread.name)

    def _drain(self, take: Take, handler: Handler, topic: str) -> None:
        while True:
            try:
                good, taken = take()
            except Exception:  # must not end the loop; retried on the next wake-up
                if topic not in self._failed_take:
                    self._failed_take.add(topic)
                    log.exception("%s: taking samples failed (further failures not logged)", topic)
                time.sleep(0.01)  # a reader that keeps failing must not spin the loop
                return
            if not taken:
                return
            if len(good) < taken and topic not in self._warned:
                self._warned.add(topic)  # a flood of bad samples must not flood the log
                log.warning("%s: dropped an undecodable sample (further ones not logged)", topic)
            try:
                if good:
                    handler(good)
            except Exception:  # a bug in one handler must not stop the thread
                log.exception("handler for %s failed", topic)
            if taken < _TAKE_BATCH:
                return
