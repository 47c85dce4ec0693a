"""The worker of one hosted node: that node's one commit path.

Every change of the node goes through its worker, whoever made it: a DDS request
(the server submits a job), a retained assignment (likewise), or the application's
own ``table.set``/``declare``/``undeclare`` (the worker's change listener queues the
change set and a flush). A request's job validates and commits through the table,
then takes the change sets that commit produced (:meth:`NodeWorker.take_pending`),
persists them, replies and publishes; a flush persists and publishes changes made
outside a request. The worker's thread is started on the first job, so a process
hosting 1,000 node ids that are never written to runs no extra threads.

The server watches :attr:`NodeWorker.busy_since` from its dispatch loop: a job that
runs for longer than the liveliness lease marks the worker stalled
(:meth:`NodeWorker.check_stall`) and the node's presence is unregistered until the job
returns, when the worker writes it again.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable, Sequence
from typing import Protocol

from ..core.results import ChangeSet
from ..core.table import ParameterTable

log = logging.getLogger(__name__)

Job = Callable[[], None]


class Persists(Protocol):
    """Where a worker persists its node's changes (:class:`.publication.Persistence`)."""

    def persist(self, table: ParameterTable, changes: Sequence[ChangeSet]) -> str:
        """Persist ``changes``; what failed ("" when nothing did)."""
        ...


class Publishes(Protocol):
    """Where a worker publishes its node's changes and presence (:class:`.publication.StatePublication`)."""

    def publish(self, table: ParameterTable, changes: Sequence[ChangeSet]) -> None: ...

    def write_presence(self, table: ParameterTable, *tags: str) -> None: ...


class NodeWorker:
    """One hosted node's commit path: a job queue and a thread of its own (started lazily)."""

    def __init__(self, persistence: Persists, publication: Publishes, table: ParameterTable) -> None:
        self.table = table
        self._persistence = persistence
        self._publication = publication
        self._jobs: queue.SimpleQueue[Job | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._pending: list[ChangeSet] = []
        self._thread: threading.Thread | None = None
        self._closed = False
        self.busy_since: float | None = None
        self.stalled = False
        self._inflight = 0  # jobs queued or running
        self._listener = table.add_change_listener(self._on_change)

    def submit(self, job: Job) -> None:
        with self._lock:
            if self._closed:
                return
            if self._thread is None:
                name = f"paramdds-node-{self.table.node_id}"[:60]
                self._thread = threading.Thread(target=self._run, name=name, daemon=True)
                self._thread.start()
            self._inflight += 1
        self._jobs.put(job)

    def _on_change(self, change: ChangeSet) -> None:
        """Change listener (under the table's lock, on any thread): queue it, in revision order."""
        with self._lock:
            self._pending.append(change)
            first = len(self._pending) == 1
        if first:  # a request's own job takes its changes itself; this flush is then a no-op
            self.submit(self.flush)

    def idle(self) -> bool:
        """No job running or queued (a read answered now cannot overtake one of its sets)."""
        return self._inflight == 0

    def take_pending(self) -> list[ChangeSet]:
        with self._lock:
            pending, self._pending = self._pending, []
        return pending

    def flush(self) -> None:
        """Persist and publish changes made outside a request (the application's own)."""
        changes = self.take_pending()
        if changes:
            failure = self._persistence.persist(self.table, changes)
            if failure:
                log.error(
                    "%s: changes up to revision %d are not persisted: %s",
                    self.table.node_id,
                    changes[-1].revision,
                    failure,
                )
            self._publication.publish(self.table, changes)

    def _run(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            with self._lock:
                self.busy_since = time.monotonic()
            try:
                job()
                self.flush()
            except Exception:  # never let one job end the node's worker
                log.exception("%s: a job failed", self.table.node_id)
            finally:
                with self._lock:
                    self.busy_since = None
                    self._inflight -= 1
                    recovered, self.stalled = self.stalled, False
                if recovered:
                    log.warning("node %r is responsive again", self.table.node_id)
                    self._publication.write_presence(self.table)

    def check_stall(self, now: float, limit: float) -> bool:
        """Mark the worker stalled once its current job has run for ``limit`` seconds."""
        with self._lock:
            if self.busy_since is None or self.stalled or now - self.busy_since < limit:
                return False
            self.stalled = True
            return True

    def close(self, timeout: float) -> None:
        with self._lock:
            self._closed = True
            thread = self._thread
        self.table.remove_change_listener(self._listener)
        if thread is not None:
            self._jobs.put(None)
            if thread is not threading.current_thread():
                thread.join(timeout)
