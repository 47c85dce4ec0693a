"""``server --persist FILE``: runtime changes and the nodes' history survive a restart, at a
cost per set that does not grow with the table.

Three files, all ours:

* ``FILE``, the **snapshot**: a ROS 2 parameter file in the dump format (with
  descriptors, so it reloads without loss), one section per hosted node, framed by
  two comment lines and checksummed::

      # paramdds persisted state: written by the server, do not edit while it runs
      robot1:
        ros__parameters:
          ...
      # paramdds epoch 5f0c…
      # paramdds end sha256=<hex of every byte above this line>

* ``FILE.journal``, the **journal**: one line per committed change set, appended and
  fsynced (``fdatasync``) before the reply is sent. Its first line names the epoch
  of the snapshot it follows and the process that holds it
  (``# paramdds journal epoch=… pid=… host=…``); each further line is
  ``<crc32> <json>``: ``[node, revision, [[name, type, value, descriptor] | [name]]]``
  (a one-element entry is a deletion), with a fourth member, the history records the
  node made with those changes (:func:`~paramdds.persist.history.record_row`), when it
  carries any: a group of sets and the records saying who made them are one line.

* ``FILE.history``, the nodes' **history** (:mod:`paramdds.persist.history`): every
  compaction moves the journal's records there before it truncates the journal, with
  the records of every change its snapshot holds (a node's change committed while
  another node's append compacts, its records still waiting for its own append), and
  retention (count and age per node) bounds it.

Guarantees:

* **Written before the reply**, and the cost of one set is one append and one
  ``fdatasync``, whatever the number of parameters. **Group commit**: a node's
  worker persists the requests committed together in one call, and changes of
  several nodes appended while a flush runs share the next one (one ``fdatasync``
  for all, as etcd and PostgreSQL do); each caller returns only once a flush that
  began after its append has succeeded. The journal is **preallocated** with zeros
  (:data:`PREALLOCATE` at a time), so a flush writes data blocks and not the file's
  size (on ext4 about half the cost of an ``fdatasync`` that grows the file); a
  reader stops at the first NUL byte (a record never holds one: JSON escapes it). Every ``compact_every``
  journal lines (and at start) the store **compacts**: it writes a new snapshot
  (temporary file, fsync, rename, fsync of the directory) under a new epoch, then
  truncates the journal and writes its new epoch line. A journal whose epoch is not
  the snapshot's is one a crash left between those two steps: everything in it is
  in the snapshot already, and it is ignored.
* **Nothing half applied.** A change set is one journal line with a checksum; a
  torn last line (a crash during the append) was never acknowledged and is
  dropped. A bad line before the last is damage: the start is refused.
* **One server per file.** The journal is locked (``flock``) while a server runs;
  a second server on the same file refuses to start, naming the holder's pid and host.
* **Never clobbers a file that is not ours.** A ``FILE`` without our header (a
  hand-written ROS 2 parameter file, say) is refused with a message that says to
  pass it with ``-p`` instead; it is never rewritten.
* **Deletes stick.** A parameter deleted at runtime is recorded (journal entry,
  then a ``# paramdds deleted {...}`` comment line inside the snapshot's frame) and
  the next start does not declare it again from the parameter files or the spec.
* **A failed write** (disk full) raises to the server, which answers NOT_PERSISTED;
  the journal is cut back to its last good line and the next change compacts, so
  it persists the whole table again.
* A damaged ``FILE`` (truncated, not YAML, wrong types, checksum) refuses the start
  with a :class:`PersistError` naming the file and the problem, and is left untouched.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import logging
import os
import secrets
import socket
import threading
import weakref
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

from ..core.descriptors import ParameterDescriptor
from ..core.history import HistoryRecord, Retention
from ..core.hosted import HostedTable
from ..core.jsonform import descriptor_of_row, descriptor_row, value_of_row, value_row
from ..core.results import ChangeKind, ChangeSet
from ..core.table import ParameterTable
from ..core.values import ParameterValue
from ..errors import FileFormatError, ParamddsError
from ._files import PersistError, atomic_write, crc_line, decode_crc_line
from .history import HistoryFile, StoredHistory

__all__ = [
    "COMPACT_EVERY",
    "HEADER",
    "PREALLOCATE",
    "PersistError",
    "PersistStore",
    "StoredHistory",
    "atomic_write",
    "encode_record",
    "frame",
    "read_journal",
    "unframe",
]

log = logging.getLogger(__name__)

HEADER = "# paramdds persisted state: written by the server, do not edit while it runs\n"
TRAILER_PREFIX = "# paramdds end sha256="
DELETED_PREFIX = "# paramdds deleted "  # + JSON {"node": id, "names": [...]}: see PersistStore
EPOCH_PREFIX = "# paramdds epoch "
JOURNAL_PREFIX = "# paramdds journal "
COMPACT_EVERY = 10_000  # journal lines between compactions (env PARAMDDS_PERSIST_COMPACT_EVERY)
PREALLOCATE = 1 << 20  # bytes of zeros the journal is extended by ahead of its appends

Entry = tuple[str, ParameterValue, ParameterDescriptor | None]
Snapshot = list[tuple[str, ParameterValue, ParameterDescriptor]]
Dumper = Callable[[Mapping[str, Snapshot]], str]
Parser = Callable[[str, str, str], list[Entry]]  # (text, file name, node id) -> entries


def _checksum(body: bytes) -> str:
    return hashlib.sha256(body).hexdigest()


def frame(body: str) -> str:
    """``body`` between the header and a trailer carrying its checksum."""
    content = HEADER + body
    if not content.endswith("\n"):
        content += "\n"
    return content + TRAILER_PREFIX + _checksum(content.encode("utf-8")) + "\n"


def unframe(raw: bytes, path: str) -> str:
    """The YAML text of a persisted file, after checking its frame (PersistError if damaged)."""
    if not raw:
        raise PersistError(
            "the file is empty (truncated?); remove it to start from the parameter files", file=path
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise PersistError(f"not UTF-8 text (byte {exc.start}); the file is damaged", file=path) from None
    if not text.startswith(HEADER):
        raise PersistError(
            "not a paramdds persistence file (it lacks our first line): it would be rewritten with only "
            "the hosted nodes; pass it with -p and give --persist a new file",
            file=path,
        )
    body, _, last = text.rstrip("\n").rpartition("\n")
    if not last.startswith(TRAILER_PREFIX):
        raise PersistError("the end line is missing: the file was truncated or damaged", file=path)
    expected = last[len(TRAILER_PREFIX) :].strip()
    if len(expected) != 64:
        raise PersistError("the end line is incomplete: the file was truncated", file=path)
    if _checksum((body + "\n").encode("utf-8")) != expected:
        raise PersistError("the content does not match its checksum: the file is damaged", file=path)
    return body + "\n"


# -- journal records: a change set as one JSON line (rows of paramdds.core.jsonform) -----------


def _entries(change: ChangeSet) -> list[list[object]]:
    return [
        [c.name]
        if c.kind is ChangeKind.DELETED
        else [c.name, *value_row(c.value), descriptor_row(c.descriptor)]
        for c in change.changes
    ]


def encode_record(change: ChangeSet) -> bytes:
    """One journal line (with its checksum and newline) for ``change``."""
    return crc_line([change.node_id, change.revision, _entries(change)])


def encode_group(
    node_id: str, revision: int, changes: Sequence[ChangeSet], rows: list[list[object]]
) -> bytes:
    """One journal line for a commit group with its history rows: the state and the records
    that say who made it are one line, never one without the other."""
    return crc_line([node_id, revision, [e for c in changes for e in _entries(c)], rows])


def _decode_line(line: bytes) -> list[object] | None:
    """The record of one journal line (``[node, revision, entries]``, with ``history rows``
    as a fourth member when it carries them), or None when its checksum or JSON is bad."""
    record = decode_crc_line(line)
    return record if isinstance(record, list) and len(record) in (3, 4) else None


def read_journal(
    raw: bytes, path: str, history: dict[str, list[list[object]]] | None = None
) -> tuple[str, dict[str, dict[str, list[object]]]]:
    """The journal's epoch and, per node, the last raw entry per name (PersistError if damaged);
    the history rows of its lines go to ``history`` (per node, in order) when given."""
    lines = raw.split(b"\0", 1)[0].split(b"\n")  # the preallocated zeros are not records
    torn = lines.pop()  # b"" when the file ends with a newline; else a line cut by a crash
    if torn:
        log.warning("%s: dropped a torn last line (a crash during an append; never acknowledged)", path)
    if not lines or not lines[0].startswith(JOURNAL_PREFIX.encode()):
        return "", {}  # empty, or cut during compaction: nothing in it that the snapshot lacks
    fields = dict(f.split("=", 1) for f in lines[0].decode(errors="replace").split()[3:] if "=" in f)
    nodes: dict[str, dict[str, list[object]]] = {}
    for number, line in enumerate(lines[1:], start=2):
        record = _decode_line(line)
        if record is None:
            if number == len(lines) and not torn:
                log.warning("%s: dropped a damaged last line (a crash during an append)", path)
                break
            raise PersistError(
                "a journal line does not match its checksum: the journal is damaged", file=path, line=number
            )
        node, entries = record[0], record[2]
        if history is not None and len(record) == 4:
            history.setdefault(str(node), []).extend(record[3])  # type: ignore[arg-type]
        last = nodes.setdefault(str(node), {})
        for entry in entries:  # type: ignore[attr-defined]
            last.pop(entry[0], None)  # re-inserted: the order of the last changes is kept
            last[entry[0]] = entry
    return fields.get("epoch", ""), nodes


class _Journal:
    """The open, locked journal file."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path = path
        self.fd = fd
        self.size = os.fstat(fd).st_size  # the end of the last line (set by restart)
        self.allocated = self.size  # the file's size: zeros from size on
        self._close = weakref.finalize(self, os.close, fd)  # a store dropped unclosed still unlocks

    @staticmethod
    def open(path: Path, *, create: bool) -> _Journal | None:
        """Open and lock ``path``; None when it does not exist and ``create`` is false."""
        flags = os.O_RDWR | (os.O_CREAT if create else 0)
        try:
            fd = os.open(path, flags | os.O_CLOEXEC, 0o644)
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise PersistError(
                f"cannot open the journal {str(path)!r}: {exc.strerror}", file=str(path)
            ) from exc
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise PersistError(
                f"in use by another server ({holder}): two servers must not share one --persist file",
                file=str(path).removesuffix(".journal"),
            ) from None
        return _Journal(path, fd)

    def read(self) -> bytes:
        return os.pread(self.fd, os.fstat(self.fd).st_size, 0)

    def write(self, data: bytes) -> None:
        """Append without a flush (:meth:`sync` makes it durable); on failure cut the file
        back to its last good line and raise."""
        end = self.size + len(data)
        try:
            if end > self.allocated:
                self.allocated = end + PREALLOCATE
                os.pwrite(self.fd, b"\0" * (self.allocated - self.size), self.size)
            os.pwrite(self.fd, data, self.size)
        except BaseException:
            self.cut()
            raise
        self.size = end

    def sync(self) -> None:
        os.fdatasync(self.fd)

    def cut(self) -> None:
        """Drop everything after the last line counted in :attr:`size` (its zeros too)."""
        with contextlib.suppress(OSError):
            os.ftruncate(self.fd, self.size)
        self.allocated = self.size

    def restart(self, epoch: str) -> None:
        """Empty the journal and start it again with ``epoch`` (after a new snapshot)."""
        header = f"{JOURNAL_PREFIX}epoch={epoch} pid={os.getpid()} host={socket.gethostname()}\n".encode()
        os.ftruncate(self.fd, 0)
        os.pwrite(self.fd, header, 0)
        os.fsync(self.fd)
        self.size = self.allocated = len(header)

    def close(self) -> None:
        self._close()  # releases the lock


def _holder(fd: int) -> str:
    first = os.pread(fd, 200, 0).split(b"\n", 1)[0].decode(errors="replace")
    fields = dict(f.split("=", 1) for f in first.split()[3:] if "=" in f)
    if "pid" in fields:
        return f"pid {fields['pid']} on host {fields.get('host', '?')}"
    return "a process that has not written its name yet"


class PersistStore:
    """The persistence files of the nodes of one server process (see the module doc)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        dumper: Dumper,
        parser: Parser,
        compact_every: int | None = None,
        retention: Retention | None = None,
    ) -> None:
        self.path = Path(path)
        self.journal_path = Path(f"{self.path}.journal")
        self.history_file = HistoryFile(Path(f"{self.path}.history"), retention)
        self._dump = dumper
        self._parse = parser
        if compact_every is None:
            compact_every = int(os.environ.get("PARAMDDS_PERSIST_COMPACT_EVERY", COMPACT_EVERY))
        self.compact_every = max(1, compact_every)
        self._lock = threading.Lock()
        self._flush = threading.Lock()  # held by the one thread running an fdatasync (the leader)
        self._appended = 0  # appends so far; the flushes below count in them
        self._flushed = 0  # appends known on disk
        self._failed = 0  # appends up to here were lost by a failed flush
        self._tables: dict[str, ParameterTable] = {}
        self._text: str | None = None
        self._replayed: dict[str, dict[str, list[object]]] | None = None
        self._replayed_rows: dict[str, list[list[object]]] = {}  # history rows of the journal
        self._waiting: dict[str, list[HistoryRecord]] = {}  # per node: records for its next append
        self._waiting_lock = threading.Lock()  # taken alone (a table's change listener takes it)
        self._deleted: dict[str, set[str]] = {}  # node -> names deleted at runtime
        self._journal: _Journal | None = None
        self._lines = 0  # journal lines since the last compaction
        self._broken = False  # the last append failed: compact on the next change

    @property
    def exists(self) -> bool:
        return self.path.exists()

    def check_writable(self) -> None:
        """Fail early (PersistError) when the file's directory cannot take our writes, or
        another server holds the file."""
        directory = self.path.parent
        if not directory.is_dir():
            raise PersistError(f"the directory {str(directory)!r} does not exist", file=str(self.path))
        if not os.access(directory, os.W_OK | os.X_OK):
            raise PersistError(f"cannot write in the directory {str(directory)!r}", file=str(self.path))
        if self._journal is None:
            self._journal = _Journal.open(self.journal_path, create=False)

    def _load(self) -> str | None:
        if self._text is None:
            if not self.path.exists():
                return None
            try:
                raw = self.path.read_bytes()
            except OSError as exc:
                raise PersistError(f"cannot read: {exc.strerror}", file=str(self.path)) from exc
            self._text = unframe(raw, str(self.path))
        return self._text

    def _journal_entries(self, node_id: str) -> dict[str, list[object]]:
        if self._replayed is None:
            self._replayed = {}
            text = self._load()
            raw = self._read_journal()
            if text is not None and raw:
                rows: dict[str, list[list[object]]] = {}
                epoch, nodes = read_journal(raw, str(self.journal_path), rows)
                if epoch and epoch == _epoch_of(text):
                    self._replayed, self._replayed_rows = nodes, rows
        return self._replayed.get(node_id, {})

    def _read_journal(self) -> bytes:
        """The journal's bytes: through our lock when we hold it, else as a reader (tools, tests)."""
        if self._journal is not None:
            return self._journal.read()
        try:
            return self.journal_path.read_bytes()
        except FileNotFoundError:
            return b""
        except OSError as exc:
            raise PersistError(f"cannot read the journal: {exc.strerror}", file=str(self.path)) from exc

    def set_retention(self, retention: Retention) -> None:
        """How much history the store keeps per node (before :meth:`attach`; the server's)."""
        self.history_file.retention = retention

    def recorded(self, node_id: str, records: Sequence[HistoryRecord]) -> None:
        """A node's history listener (:meth:`NodeHistory.add_listener`): its new records wait
        for the node's next persist call, which writes them in the line of their changes. A
        batch of refusals with nothing waiting is written at once (append and
        ``fdatasync``): no persist call may follow a request that changed nothing."""
        with self._waiting_lock:
            waiting = self._waiting.setdefault(node_id, [])
            idle = not waiting
            waiting.extend(records)
        if idle and records and not any(r.applied for r in records):
            self.write_history(node_id)

    def _take_waiting(self, node_id: str) -> list[HistoryRecord]:
        with self._waiting_lock:
            return self._waiting.pop(node_id, [])

    def write_history(self, node_id: str | None = None) -> None:
        """Write the records waiting (of ``node_id``, or of every node) now, durably."""
        with self._waiting_lock:
            nodes = [node_id] if node_id is not None else list(self._waiting)
        last = 0
        for node in nodes:  # one append per node, one fdatasync for them all
            last = max(last, self._append(node, (), wait=False))
        if last:
            self._wait_flushed(last)

    def history(self, node_id: str) -> StoredHistory:
        """The persisted history of ``node_id``: its records (retention applied with the time
        now), each parameter's last change and the dropped watermark (see
        :mod:`paramdds.persist.history`); empty when it has none yet."""
        self._load_history()
        return self.history_file.stored(node_id)

    def _load_history(self) -> None:
        if not self.history_file.loaded:
            self._journal_entries("")  # reads the journal's rows, when it follows the snapshot
            self.history_file.load(self._replayed_rows)
            self._replayed_rows = {}  # the history file holds them now

    def deleted(self, node_id: str) -> list[str]:
        """Names of ``node_id`` deleted at runtime: a restart must not bring them back from
        the parameter files or the spec. Kept as comment lines inside the checksummed
        frame, so the file stays a plain ROS 2 parameter file."""
        if node_id not in self._deleted:
            names: set[str] = set()
            for number, line in enumerate((self._load() or "").splitlines(), start=1):
                if line.startswith(DELETED_PREFIX):
                    try:
                        record = json.loads(line[len(DELETED_PREFIX) :])
                        if record["node"] == node_id:
                            names.update(str(n) for n in record["names"])
                    except (ValueError, KeyError, TypeError) as exc:
                        raise PersistError(
                            f"bad deletion record: {exc}", file=str(self.path), line=number
                        ) from exc
            for name, entry in self._journal_entries(node_id).items():
                if len(entry) == 1:
                    names.add(name)
                else:
                    names.discard(name)
            self._deleted[node_id] = names
        return sorted(self._deleted[node_id])

    def read(self, node_id: str) -> list[Entry]:
        """The persisted entries of ``node_id`` ([] when the file does not exist yet)."""
        if self._load() is None:
            return []
        assert self._text is not None
        try:
            entries = self._parse(self._text, str(self.path), node_id)
        except PersistError:
            raise
        except FileFormatError as exc:
            raise PersistError(exc.detail, file=str(self.path), line=exc.line) from exc
        replayed = self._journal_entries(node_id)
        if not replayed:
            return entries
        out = [e for e in entries if e[0] not in replayed]
        for name, entry in replayed.items():
            if len(entry) == 1:
                continue  # deleted
            try:
                _, t, data, desc = entry
                out.append((name, value_of_row([t, data]), descriptor_of_row(name, desc)))
            except (ValueError, TypeError, ParamddsError) as exc:
                raise PersistError(
                    f"bad journal entry for {node_id}/{name}: {exc}", file=str(self.journal_path)
                ) from exc
        return out

    def attach(self, tables: Mapping[str, ParameterTable]) -> None:
        """Persist these tables from now on: lock the journal and compact at once."""
        self._tables = dict(tables)
        for node in self._tables:
            self.deleted(node)  # carry the file's deletion records into every rewrite
        self._load_history()
        if self._journal is None:
            self._journal = _Journal.open(self.journal_path, create=True)
        assert self._journal is not None
        with self._lock:
            self._compact()

    def close(self) -> None:
        """Write the history records still waiting, release the lock (the files stay as they are)."""
        if self._journal is not None:
            try:
                self.write_history()
            except OSError:
                log.exception("%s: history records not written at close", self.path)
        with self._flush, self._lock:
            if self._journal is not None:
                self._journal.close()
                self._journal = None

    def write(self) -> None:
        """Write the state of every attached table (a compaction)."""
        with self._lock:
            self._compact()

    def _compact(self) -> None:
        assert self._journal is not None
        state = {}
        for node, table in self._tables.items():
            # the records of the changes the snapshot holds go with it: one still waiting for its
            # node's append (another node's append compacts) would be lost with a crash before it
            with table.locked():  # the change listeners that queue records run under this lock
                state[node] = table.snapshot()
                waiting = self._take_waiting(node)
            if waiting:
                self.history_file.add(node, waiting)
                # and so do its deletions: without their records the snapshot drops a deleted
                # name while a restart brings it back from the parameter files or the spec
                self._note_deleted(node, ((r.name, r.new is None) for r in waiting if r.applied))
            # a name the snapshot holds is not deleted, though an append that took the record of
            # its re-declaration noted only its own changes' deletion: a restart would leave it out
            self._deleted.get(node, set()).difference_update(name for name, _, _ in state[node])
        self.history_file.checkpoint()  # the journal's records first: it is truncated below
        epoch = secrets.token_hex(8)
        records = [
            DELETED_PREFIX + json.dumps({"node": node, "names": sorted(names)}) + "\n"
            for node, names in sorted(self._deleted.items())
            if names and node in self._tables
        ]
        atomic_write(self.path, frame(self._dump(state) + "".join(records) + EPOCH_PREFIX + epoch + "\n"))
        self._journal.restart(epoch)
        self._lines = 0
        self._broken = False
        self._flushed = self._appended  # the snapshot holds every table's state

    def _note_deleted(self, node_id: str, changed: Iterable[tuple[str, bool]]) -> None:
        """Keep the node's deletion records in step with ``changed`` ((name, deleted), in
        the order applied): a name declared again is no longer deleted."""
        deleted = self._deleted.setdefault(node_id, set())
        for name, gone in changed:
            if gone:
                deleted.add(name)
            else:
                deleted.discard(name)

    def record(
        self, table: HostedTable, changes: Sequence[ChangeSet], records: Sequence[HistoryRecord] = ()
    ) -> None:
        """The server's persister: the changes, with the history records waiting for the node
        (:meth:`recorded`) and ``records``, reach the disk before the reply is sent."""
        self._append(table.node_id, changes, records)

    def _append(
        self,
        node_id: str,
        changes: Sequence[ChangeSet],
        records: Sequence[HistoryRecord] = (),
        *,
        wait: bool = True,
    ) -> int:
        """Append the node's line; with ``wait``, return once it is on disk. The append's
        number (0: nothing to wait for)."""
        with self._lock:  # taken before the records: a compaction takes them under it too
            records = [*self._take_waiting(node_id), *records]
            if not changes and not records:
                return 0
            if self._journal is None:
                raise PersistError("the persistence store is closed", file=str(self.path))
            if records:
                rows = self.history_file.add(node_id, records)
                revision = changes[-1].revision if changes else records[-1].revision
                data = encode_group(node_id, revision, changes, rows)
            else:
                data = b"".join(encode_record(c) for c in changes)
            changed = (c for change in changes for c in change.changes)
            self._note_deleted(node_id, ((c.name, c.kind is ChangeKind.DELETED) for c in changed))
            if self._broken:
                self._compact()  # the last append failed: the snapshot covers everything
                return 0
            try:
                self._journal.write(data)
            except OSError:
                self._broken = True
                raise
            self._appended += 1
            mine = self._appended
            self._lines += max(1, len(changes))
            if self._lines >= self.compact_every:
                self._compact()
                return 0
        if wait:
            self._wait_flushed(mine)
        return mine

    def _wait_flushed(self, mine: int) -> None:
        """Return once append number ``mine`` is on disk: one thread flushes at a time, and
        every append made before its flush began is covered by it (group commit)."""
        with self._flush:
            if self._flushed >= mine:  # a flush that began after our append covered it
                return
            if self._failed >= mine:
                raise OSError(f"the flush of {self.journal_path} failed")
            with self._lock:
                journal, upto = self._journal, self._appended
            if journal is None:
                raise PersistError("the persistence store is closed", file=str(self.path))
            try:
                journal.sync()
            except OSError:
                # never trust a later flush with what this one held (Linux may report the
                # next one clean and the data lost): those appends fail, the next change compacts
                with self._lock:
                    self._failed = upto
                    self._broken = True
                raise
            self._flushed = max(self._flushed, upto)


def _epoch_of(text: str) -> str:
    for line in reversed(text.splitlines()):
        if line.startswith(EPOCH_PREFIX):
            return line[len(EPOCH_PREFIX) :].strip()
    return ""
