"""``paramdds record``: a monitor's every change, with its author, written to MCAP until SIGINT or SIGTERM.

The file is created first (a path that cannot be written is exit 2 at once). The monitor
(over DDS, or with ``--zenoh`` every site's) queues its events from the start; once
discovery has settled the recorder takes its state as each node's snapshot,
writes it, flushes, and prints ``[RECORD] Recording N nodes to FILE`` (``1 node``). Then the main
thread turns the queued events into messages (:mod:`.tracker`: each change once; revisions
the monitor skipped filled from the node's history, or recorded as a gap) and writes them
(:mod:`.mcapfile`), flushing within :data:`~.mcapfile.FLUSH_S` of each message. SIGINT and
SIGTERM set a flag the loop sees: the queue is drained, the file finished (summary,
footer), exit 0. With ``--split`` a full file is finished and the next one starts with
a snapshot of every node.
"""

from __future__ import annotations

import argparse
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from types import FrameType
from typing import TYPE_CHECKING

from ..core.history import HistoryRecord, Outcome
from ..core.monitor_events import MonitorEvent
from ..errors import NoHistoryError, ParamddsError
from ..exits import Exit, UsageError
from ..session import Session
from .mcapfile import McapFile, Split, parse_split, part_path
from .tracker import Out, Tracker

if TYPE_CHECKING:
    from ..dds.client import ParameterClient

TICK = 0.2  # seconds the loop waits for an event at most (how soon a signal is seen)


class Recorder:
    """One recording: its tracker, its current file, and the parts written."""

    def __init__(self, path: str, split: Split, client_history: HistoryFill) -> None:
        self.path = path
        self.split = split
        self.part = 0
        self.tracker = Tracker(client_history)
        self.file: McapFile | None = None

    def open_next(self) -> McapFile:
        self.part += 1
        path = part_path(self.path, self.part) if (self.split.size or self.split.seconds) else self.path
        try:
            self.file = McapFile(path)
        except OSError as exc:
            raise UsageError(str(exc)) from None
        return self.file

    def flush(self) -> None:
        if self.file is not None:
            self.file.flush()

    def write(self, messages: Sequence[Out]) -> None:
        assert self.file is not None
        for channel, body, log_time in messages:
            self.file.write(channel, body, log_time)

    def roll(self) -> None:
        """Finish a full file and start the next with every node's snapshot."""
        assert self.file is not None
        self.file.finish()
        nxt = self.open_next()
        self.write(self.tracker.snapshots(time.time_ns()))
        nxt.flush()
        _say(f"[RECORD] Recording {_nodes(self.tracker.nodes)} to {nxt.path}")


class HistoryFill:
    """Reads the revisions a monitor skipped from the node's history (the tracker's ``fill``).

    ``before`` runs first (the recorder flushes what it holds: a read may take up to
    ``--timeout``, and a kill meanwhile must not cost more than the flush interval). A node
    that said it keeps no history is not asked again."""

    def __init__(self, session: Session) -> None:
        self._session = session
        self._client: ParameterClient | None = None
        self._none: set[str] = set()  # nodes that keep no history
        self.before: Callable[[], None] = lambda: None

    def __call__(self, node: str, after: int, before: int) -> tuple[Sequence[HistoryRecord], str]:
        if node in self._none:
            return (), "the node keeps no history"
        self.before()
        if self._client is None:
            self._client = self._session.client()
        try:
            reply = self._client.history(node, since_revision=after, outcome=Outcome.APPLIED)
        except NoHistoryError:
            self._none.add(node)
            return (), "the node keeps no history"
        except ParamddsError as exc:
            return (), f"the node's history could not be read: {exc}"
        records: Sequence[HistoryRecord] = reply.records
        return [r for r in records if r.revision < before], "retention dropped it" if reply.compacted else ""


def run_record(args: argparse.Namespace, nodes: list[str]) -> int:
    """Record ``nodes`` (ids and globs; none: every node) to ``args.output_file`` until SIGINT
    or SIGTERM, split by ``args.split``; exit 0 once the file is finished."""
    split = Split()
    if args.split is not None:
        try:
            split = parse_split(args.split)
        except ValueError as exc:
            raise UsageError(f"--split: {exc}") from None
    stop = threading.Event()
    events: queue.Queue[MonitorEvent] = queue.Queue()
    def on_event(e: MonitorEvent) -> None:
        events.put(e)

    def on_signal(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        with Session(args) as session:
            fill = HistoryFill(session)
            recorder = Recorder(args.output_file, split, fill)
            fill.before = recorder.flush
            file = recorder.open_next()  # first: a path that cannot be written fails at once
            started = time.monotonic()
            monitor = session.monitor(nodes or None, on_event=on_event)
            monitor.settle(args.timeout, started=started, stop=stop)
            recorder.write(recorder.tracker.start(monitor.snapshot(), time.time_ns()))
            file.flush()
            _say(f"[RECORD] Recording {_nodes(recorder.tracker.nodes)} to {file.path}")
            try:
                _loop(recorder, events, stop)
            finally:
                while not events.empty():  # what came before the stop is recorded too
                    recorder.write(recorder.tracker.on_event(events.get_nowait(), time.time_ns()))
                assert recorder.file is not None
                recorder.file.finish()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    return Exit.OK


def _loop(recorder: Recorder, events: queue.Queue[MonitorEvent], stop: threading.Event) -> None:
    while not stop.is_set():
        file = recorder.file
        assert file is not None
        due = file.due()
        try:
            e = events.get(timeout=TICK if due is None else min(TICK, due))
        except queue.Empty:
            pass
        else:
            recorder.write(recorder.tracker.on_event(e, time.time_ns()))
        if file.due() == 0.0:
            file.flush()
            if file.full(recorder.split):
                recorder.roll()
        elif recorder.split.seconds and file.full(recorder.split):
            file.flush()
            recorder.roll()


def _say(line: str) -> None:
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def _nodes(count: int) -> str:
    return f"{count} node" if count == 1 else f"{count} nodes"
