"""The worker of one hosted node: that node's one commit path.

Every change of the node goes through its worker, whoever made it: a DDS request
(the server submits a job), a retained assignment (likewise), or the application's
own ``table.set``/``declare``/``undeclare`` (the worker's change listener queues the
change set and a flush). A request's job validates and commits through the table,
then takes the change sets that commit produced (:meth:`NodeWorker.take_pending`),
persists them, replies and publishes; a flush persists and publishes changes made
outside a request. The worker's thread is started on the first job, so a process
hosting 1,000 node ids that are never written to runs no extra threads.

**Group commit.** A request's set is submitted as a :data:`Commit` (its first half:
validate, commit, take its change sets) that returns a :class:`Staged` (its second
half: the reply, given what failed to persist). When the worker takes such a job it
also takes every commit queued right behind it (up to :data:`GROUP_MAX`), runs their
first halves in order, persists all their changes with one call (one journal append,
one ``fdatasync``), then replies to each in order, calls ``replied`` (the server sends
the group's replies together: one datagram per client reader) and publishes. So N
clients setting one node concurrently share one flush, and no reply leaves before its
change is on disk. A plain job (a queued get, a presence write) ends the group: it runs
after the group's replies, so it never overtakes them.

The group is what queued while the worker ran the group before (its flush, replies and
publication). There is no second thread that flushes, replies and publishes while the
worker commits the next group (which would let a flush cover about N requests): its
extra hand-off per group cost more than the larger groups gained (docs/decisions.md,
"One thread per node's commits").

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

from ..core.history import NodeHistory
from ..core.hosted import HostedTable
from ..core.results import ChangeSet

log = logging.getLogger(__name__)

Job = Callable[[], None]
GROUP_MAX = 64  # commits that share one persist call at most


class Staged:
    """The second half of a committed request: its change sets, and its reply once they
    are persisted (``reply(failure)``, ``failure`` "" when they reached the disk)."""

    __slots__ = ("changes", "reply")

    def __init__(self, changes: Sequence[ChangeSet], reply: Callable[[str], None]) -> None:
        self.changes = changes
        self.reply = reply


Commit = Callable[[], "Staged | None"]


class _Grouped:
    """A queued :data:`Commit` (one the worker may group with the commits behind it)."""

    __slots__ = ("commit",)

    def __init__(self, commit: Commit) -> None:
        self.commit = commit


_EMPTY = object()


class Persists(Protocol):
    """Where a worker persists its node's changes (:class:`.publication.Persistence`)."""

    def persist(self, table: HostedTable, changes: Sequence[ChangeSet]) -> str:
        """Persist ``changes``; what failed ("" when nothing did)."""
        ...


class Publishes(Protocol):
    """Where a worker publishes its node's changes and presence (:class:`.publication.StatePublication`)."""

    def publish(self, table: HostedTable, changes: Sequence[ChangeSet]) -> None: ...

    def write_presence(self, table: HostedTable, *tags: str) -> None: ...


class NodeWorker:
    """One hosted node's commit path: a job queue and a thread of its own (started lazily)."""

    def __init__(
        self,
        persistence: Persists,
        publication: Publishes,
        table: HostedTable,
        *,
        replied: Callable[[], None] = lambda: None,
        history: NodeHistory | None = None,
    ) -> None:
        self.table = table
        self.history = history or NodeHistory(table.node_id)  # what the node applied and refused
        self._replied = replied  # after a group's replies are written: sends them together
        self._persistence = persistence
        self._publication = publication
        self._jobs: queue.SimpleQueue[Job | _Grouped | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._pending: list[ChangeSet] = []
        self._thread: threading.Thread | None = None
        self._closed = False
        self.busy_since: float | None = None
        self.stalled = False
        self._inflight = 0  # jobs queued or running
        self._listener = table.add_change_listener(self._on_change)

    def submit(self, job: Job) -> None:
        self._put(job)

    def submit_commit(self, commit: Commit) -> None:
        """Queue a request's commit: run with the commits queued beside it, which share one
        persist call; its :class:`Staged` reply runs after that call returns."""
        self._put(_Grouped(commit))

    def _put(self, job: Job | _Grouped) -> None:
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
        """Change listener (under the table's lock, on any thread): record it in the history and
        queue it, in revision order."""
        self.history.applied(change)
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
        self._commit_group([])

    def _run(self) -> None:
        item = self._jobs.get()
        while item is not None:
            batch: list[Job | _Grouped] = [item]
            jobs = 1  # taken from the queue: the batch and the no-op flushes it absorbed
            after: object = _EMPTY
            if isinstance(item, _Grouped):  # take the commits queued behind it: one flush for all
                while len(batch) < GROUP_MAX:
                    try:
                        after = self._jobs.get_nowait()
                    except queue.Empty:
                        after = _EMPTY
                        break
                    jobs += 1
                    if after == self.flush:  # queued by a commit's own change: the group takes it
                        after = _EMPTY
                        continue
                    if not isinstance(after, _Grouped):
                        jobs -= 1
                        break
                    batch.append(after)
                    after = _EMPTY
            with self._lock:
                self.busy_since = time.monotonic()
            try:
                if isinstance(item, _Grouped):
                    self._commit_group(batch)  # type: ignore[arg-type]
                elif item == self.flush and not self._pending:
                    pass  # a commit took the changes it was queued for
                else:
                    item()
                    self.flush()
            except Exception:  # never let one job end the node's worker
                log.exception("%s: a job failed", self.table.node_id)
            finally:
                with self._lock:
                    self.busy_since = None
                    self._inflight -= jobs
                    recovered = self.stalled
                    self.stalled = False
                if recovered:
                    log.warning("node %r is responsive again", self.table.node_id)
                    self._publication.write_presence(self.table)
            item = self._jobs.get() if after is _EMPTY else after  # type: ignore[assignment]

    def _commit_group(self, batch: list[_Grouped]) -> None:
        """First halves in order; then one persist call for all their changes (and the
        application's own, made meanwhile), the replies in order, and one publication. With
        no commits it is :meth:`flush`."""
        staged: list[Staged] = []
        for grouped in batch:
            try:
                done = grouped.commit()
            except Exception:
                log.exception("%s: a job failed", self.table.node_id)
                continue
            if done is not None:
                staged.append(done)
        outside = self.take_pending()
        changes = [c for s in staged for c in s.changes] + outside
        failure = self._persistence.persist(self.table, changes) if changes else ""
        if failure and outside:
            log.error(
                "%s: changes up to revision %d are not persisted: %s",
                self.table.node_id,
                outside[-1].revision,
                failure,
            )
        for done in staged:
            try:
                done.reply(failure if done.changes else "")
            except Exception:
                log.exception("%s: a reply failed", self.table.node_id)
        if staged:
            self._replied()
        if changes:
            self._publication.publish(self.table, changes)

    def check_stall(self, now: float, limit: float) -> bool:
        """Mark the worker stalled once its current job has run for ``limit`` seconds."""
        with self._lock:
            since = self.busy_since
            if since is None or self.stalled or now - since < limit:
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
