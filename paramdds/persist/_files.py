"""The two ways the persistence files reach the disk: a whole file replaced atomically, and
checksummed lines (``<crc32> <json>``) appended to a journal or a history file."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
import zlib
from pathlib import Path

from ..errors import FileFormatError

_JSON = json.JSONDecoder()


class PersistError(FileFormatError):
    """The persistence file cannot be used; the server must not start."""


def atomic_write(path: Path, text: str | bytes) -> None:
    """Replace ``path`` with ``text``: temp file in the same directory, fsync, rename, fsync dir."""
    directory = path.parent
    data = text.encode("utf-8") if isinstance(text, str) else text
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    fsync_directory(directory)


def fsync_directory(directory: Path) -> None:
    """Make a file created or renamed in ``directory`` durable."""
    dir_fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def crc_line(record: object) -> bytes:
    """``record`` as one checksummed JSON line (ASCII, newline included)."""
    payload = json.dumps(record, separators=(",", ":")).encode()
    return b"%08x %s\n" % (zlib.crc32(payload), payload)


def decode_crc_line(line: bytes) -> object | None:
    """The record of one checksummed line (without its newline), or None when its checksum
    or JSON is bad."""
    crc, _, payload = line.partition(b" ")
    try:
        if len(crc) != 8 or int(crc, 16) != zlib.crc32(payload):
            return None
        record, end = _JSON.raw_decode(payload.decode())  # ~2x json.loads on 100,000 lines
        if end != len(payload):  # ASCII only (json.dumps escapes the rest): chars == bytes
            return None
    except ValueError:  # incl. UnicodeDecodeError
        return None
    result: object = record
    return result
