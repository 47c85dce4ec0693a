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
one ``fdatasync``), then replies to each in order and publishes. So N clients setting
one node concurrently share one flush, and no reply leaves before its change is on
disk. A plain job (a queued get, a presence write) ends the group: it runs after the
group's replies, so it never overtakes them.

**Pipelined** when the server persists (``--persist``): the worker hands a committed
group to the node's *completer* thread (started on first use), which persists, replies
and publishes, while the worker goes on committing the requests that arrived during the
flush; the completer takes every group handed to it meanwhile in one persist call. So
with N clients a flush covers about N requests, not N/2 (without the pipeline, the
requests whose replies left at the end of one flush arrive during the next). A plain job
waits until the completer has replied to every group before it (a get never reads a
value that is not on disk yet). A stall of either thread is reported.

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
GROUP_MAX = 64  # commits that share one persist call at most


class Staged:
    """The second half of a committed request: its change sets, and its reply once they
    are persisted (``reply(failure)``, ``failure`` "" when they reached the disk)."""

    __slots__ = ("changes", "reply")

    def __init__(self, changes: Sequence[ChangeSet], reply: Callable[[str], None]) -> None:
        self.changes = changes
        self.reply = reply


Commit = Callable[[], "Staged | None"]


class _Handed:
    """Committed groups handed to the completer: their reply halves, their changes and the
    application's own, and how many jobs they were."""

    __slots__ = ("changes", "jobs", "outside", "staged")

    def __init__(self, staged: list[Staged], changes: list[ChangeSet], outside: list[ChangeSet], jobs: int):
        self.staged, self.changes, self.outside, self.jobs = staged, changes, outside, jobs


class _Grouped:
    """A queued :data:`Commit` (one the worker may group with the commits behind it)."""

    __slots__ = ("commit",)

    def __init__(self, commit: Commit) -> None:
        self.commit = commit


_EMPTY = object()


class Persists(Protocol):
    """Where a worker persists its node's changes (:class:`.publication.Persistence`)."""

    @property
    def active(self) -> bool:
        """Whether anything is persisted (the worker then flushes on its completer)."""
        ...

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
        self._jobs: queue.SimpleQueue[Job | _Grouped | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._pending: list[ChangeSet] = []
        self._thread: threading.Thread | None = None
        self._closed = False
        self.busy_since: float | None = None
        self.stalled = False
        self._inflight = 0  # jobs queued or running
        self._handed: queue.SimpleQueue[_Handed | None] = queue.SimpleQueue()
        self._completer: threading.Thread | None = None
        self._completing_since: float | None = None  # the completer's current flush began
        self._unfinished = 0  # groups handed to the completer and not yet replied to
        self._finished = threading.Condition(self._lock)
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
            handed = False
            try:
                if isinstance(item, _Grouped):
                    handed = self._commit_group(batch, jobs)  # type: ignore[arg-type]
                elif item == self.flush and not self._pending:
                    pass  # a commit took the changes it was queued for
                else:
                    self._wait_finished()  # after the replies of every group before it
                    item()
                    self.flush()
            except Exception:  # never let one job end the node's worker
                log.exception("%s: a job failed", self.table.node_id)
            finally:
                with self._lock:
                    self.busy_since = None
                    if not handed:
                        self._inflight -= jobs
                    recovered = self.stalled and self._completing_since is None
                    if recovered:
                        self.stalled = False
                if recovered:
                    log.warning("node %r is responsive again", self.table.node_id)
                    self._publication.write_presence(self.table)
            item = self._jobs.get() if after is _EMPTY else after  # type: ignore[assignment]
        if self._completer is not None:
            self._handed.put(None)

    def _commit_group(self, batch: list[_Grouped], jobs: int) -> bool:
        """First halves in order; then one persist call for all their changes, the replies in
        order and one publication: on the completer when the server persists (True: handed),
        else here."""
        staged: list[Staged] = []
        for grouped in batch:
            try:
                done = grouped.commit()
            except Exception:
                log.exception("%s: a job failed", self.table.node_id)
                continue
            if done is not None:
                staged.append(done)
        changes = [c for s in staged for c in s.changes]
        outside = self.take_pending()  # the application's own, made meanwhile
        handed = _Handed(staged, changes + outside, outside, jobs)
        with self._lock:
            # nothing to flush and nothing before it unreplied (a refusal, say): reply here
            inline = not self._persistence.active or not (handed.changes or self._unfinished)
            if not inline:
                self._unfinished += 1
                if self._completer is None:
                    name = f"paramdds-flush-{self.table.node_id}"[:60]
                    self._completer = threading.Thread(target=self._complete, name=name, daemon=True)
                    self._completer.start()
        if inline:
            self._finish(handed)
            return False
        self._handed.put(handed)
        return True

    def _finish(self, handed: _Handed) -> None:
        """Persist the changes (one call), then reply to each request in order, then publish."""
        failure = self._persistence.persist(self.table, handed.changes) if handed.changes else ""
        if failure and handed.outside:
            log.error(
                "%s: changes up to revision %d are not persisted: %s",
                self.table.node_id,
                handed.outside[-1].revision,
                failure,
            )
        for done in handed.staged:
            try:
                done.reply(failure if done.changes else "")
            except Exception:
                log.exception("%s: a reply failed", self.table.node_id)
        if handed.changes:
            self._publication.publish(self.table, handed.changes)

    def _complete(self) -> None:
        """The completer: every group handed to it since its last flush shares the next one."""
        first = self._handed.get()
        while first is not None:
            groups = [first]
            after: object = _EMPTY
            while True:
                try:
                    after = self._handed.get_nowait()
                except queue.Empty:
                    after = _EMPTY
                    break
                if after is None:
                    break
                groups.append(after)  # type: ignore[arg-type]
            with self._lock:
                self._completing_since = time.monotonic()
            try:
                self._finish(
                    _Handed(
                        [d for g in groups for d in g.staged],
                        [c for g in groups for c in g.changes],
                        [c for g in groups for c in g.outside],
                        0,
                    )
                )
            except Exception:
                log.exception("%s: a flush failed", self.table.node_id)
            finally:
                with self._lock:
                    self._completing_since = None
                    self._inflight -= sum(g.jobs for g in groups)
                    self._unfinished -= len(groups)
                    self._finished.notify_all()
                    recovered = self.stalled and self.busy_since is None
                    if recovered:
                        self.stalled = False
                if recovered:
                    log.warning("node %r is responsive again", self.table.node_id)
                    self._publication.write_presence(self.table)
            if after is None:
                return
            first = self._handed.get()

    def _wait_finished(self) -> None:
        with self._lock:
            while self._unfinished:
                self._finished.wait()

    def check_stall(self, now: float, limit: float) -> bool:
        """Mark the worker stalled once its current job (or its completer's flush) has run for
        ``limit`` seconds."""
        with self._lock:
            since = min((t for t in (self.busy_since, self._completing_since) if t is not None), default=None)
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
            self._jobs.put(None)  # the worker then stops its completer, after the groups handed to it
            if thread is not threading.current_thread():
                end = time.monotonic() + timeout
                thread.join(timeout)
                completer = self._completer
                if completer is not None and completer is not threading.current_thread():
                    completer.join(max(0.0, end - time.monotonic()))
