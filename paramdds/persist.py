"""``server --persist FILE``: runtime changes survive a restart.

The file is a ROS 2 parameter file in the dump format (with descriptors, so it
reloads without loss), one section per hosted node, framed by two comment lines::

    # paramdds persisted state: written by the server, do not edit while it runs
    robot1:
      ros__parameters:
        ...
    # paramdds end sha256=<hex of every byte above this line>

Guarantees:

* **Written before the reply.** :meth:`PersistStore.hook` is a
  ``ParameterServer.before_reply`` hook: a change is on disk before the client
  hears it was applied, so a restart loses nothing that was acknowledged.
* **Deletes stick.** A parameter deleted at runtime is recorded in a
  ``# paramdds deleted {...}`` comment line (inside the frame, so checksummed, and
  invisible to ROS tools); the next start does not declare it again from the
  parameter files or the spec. Declaring it again at runtime drops the record.
* **Never half written.** Each write goes to a temporary file in the same
  directory, is fsynced, renamed over the old file and the directory fsynced.
* **Never silently replaced.** A file that starts with the header but lacks the
  end line or whose checksum does not match (truncated, damaged), that is not
  YAML, or whose values do not fit the node refuses the start with a
  :class:`PersistError` naming the file and the problem, and is left untouched.
  A file without the header is accepted as a hand-written ROS 2 parameter file.
  An empty file is refused (a truncation to zero bytes looks exactly like it).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import tempfile
import threading
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from .core.descriptors import ParameterDescriptor
from .core.results import ChangeKind, ChangeSet
from .core.table import ParameterTable
from .core.values import ParameterValue
from .errors import FileFormatError

log = logging.getLogger(__name__)

HEADER = "# paramdds persisted state: written by the server, do not edit while it runs\n"
TRAILER_PREFIX = "# paramdds end sha256="
DELETED_PREFIX = "# paramdds deleted "  # + JSON {"node": id, "names": [...]}: see PersistStore

Entry = tuple[str, ParameterValue, ParameterDescriptor | None]
Snapshot = list[tuple[str, ParameterValue, ParameterDescriptor]]
Dumper = Callable[[Mapping[str, Snapshot]], str]
Parser = Callable[[str, str, str], list[Entry]]  # (text, file name, node id) -> entries


class PersistError(FileFormatError):
    """The persistence file cannot be used; the server must not start."""


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
        return text  # a hand-written ROS 2 parameter file
    body, _, last = text.rstrip("\n").rpartition("\n")
    if not last.startswith(TRAILER_PREFIX):
        raise PersistError("the end line is missing: the file was truncated or damaged", file=path)
    expected = last[len(TRAILER_PREFIX) :].strip()
    if len(expected) != 64:
        raise PersistError("the end line is incomplete: the file was truncated", file=path)
    if _checksum((body + "\n").encode("utf-8")) != expected:
        raise PersistError("the content does not match its checksum: the file is damaged", file=path)
    return body + "\n"


def atomic_write(path: Path, text: str) -> None:
    """Replace ``path`` with ``text``: temp file in the same directory, fsync, rename, fsync dir."""
    directory = path.parent
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    dir_fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


class PersistStore:
    """One persistence file for the nodes of one server process."""

    def __init__(self, path: str | os.PathLike[str], *, dumper: Dumper, parser: Parser) -> None:
        self.path = Path(path)
        self._dump = dumper
        self._parse = parser
        self._lock = threading.Lock()
        self._tables: dict[str, ParameterTable] = {}
        self._text: str | None = None
        self._deleted: dict[str, set[str]] = {}  # node -> names deleted at runtime

    @property
    def exists(self) -> bool:
        return self.path.exists()

    def check_writable(self) -> None:
        """Fail early (PersistError) when the file's directory cannot take our writes."""
        directory = self.path.parent
        if not directory.is_dir():
            raise PersistError(f"the directory {str(directory)!r} does not exist", file=str(self.path))
        if not os.access(directory, os.W_OK | os.X_OK):
            raise PersistError(f"cannot write in the directory {str(directory)!r}", file=str(self.path))

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
            self._deleted[node_id] = names
        return sorted(self._deleted[node_id])

    def read(self, node_id: str) -> list[Entry]:
        """The persisted entries of ``node_id`` ([] when the file does not exist yet)."""
        if self._load() is None:
            return []
        assert self._text is not None
        try:
            return self._parse(self._text, str(self.path), node_id)
        except PersistError:
            raise
        except FileFormatError as exc:
            raise PersistError(exc.detail, file=str(self.path), line=exc.line) from exc

    def attach(self, tables: Mapping[str, ParameterTable]) -> None:
        """Persist these tables from now on, and write their current state at once."""
        self._tables = dict(tables)
        for node in self._tables:
            self.deleted(node)  # carry the file's deletion records into every rewrite
        self.write()

    def write(self) -> None:
        """Write the state of every attached table (atomically)."""
        with self._lock:
            state = {node: table.snapshot() for node, table in self._tables.items()}
            records = [
                DELETED_PREFIX + json.dumps({"node": node, "names": sorted(names)}) + "\n"
                for node, names in sorted(self._deleted.items())
                if names and node in self._tables
            ]
            atomic_write(self.path, frame(self._dump(state) + "".join(records)))

    def record(self, table: ParameterTable, changes: Sequence[ChangeSet]) -> None:
        """The server's persister: the changes reach the disk before the reply is sent."""
        for change in changes:
            self.hook(table.node_id, table, change)

    def hook(self, node_id: str, table: ParameterTable, change: ChangeSet) -> None:
        """The ``before_reply`` hook: the change reaches the disk before the reply is sent."""
        log.debug("persisting %s at revision %d", node_id, change.revision)
        with self._lock:
            deleted = self._deleted.setdefault(node_id, set())
            for c in change.changes:
                if c.kind is ChangeKind.DELETED:
                    deleted.add(c.name)
                else:
                    deleted.discard(c.name)  # declared again
        self.write()
