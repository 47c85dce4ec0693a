"""The recording's MCAP files: one open file written chunk by chunk, closed on time, rolled on size or age.

:class:`McapFile` wraps the ``mcap`` package's ``Writer``: chunked, zstd-compressed (JSON of
repeated keys; Foxglove, Lichtblick, ``mcap`` and ``@mcap/core`` all read it), its
channels registered at the start (:data:`paramdds.formats.recording.CHANNELS`). A chunk
is written when it holds :data:`CHUNK_BYTES` or when :meth:`McapFile.due` says the time is
up (the recorder flushes every :data:`FLUSH_S` seconds): a chunk not yet written is lost
when the process is killed, so a ``kill -9`` loses at most that long of messages.
:meth:`McapFile.finish` writes the summary and footer (SIGINT, SIGTERM, a roll).

:func:`parse_split` reads ``--split SIZE|DURATION``; :func:`part_path` names the files of
a split recording (``rec.mcap`` → ``rec-0001.mcap``, ``rec-0002.mcap``, …).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from mcap.writer import CompressionType, Writer

from ..formats import recording as fmt
from ..formats.recording import Channel

FLUSH_S = 1.0  # seconds a written message waits at most before its chunk is closed and flushed
CHUNK_BYTES = 1024 * 1024  # a chunk is closed at this size too (the mcap default)

_SIZE = re.compile(r"(\d+(?:\.\d+)?)\s*(B|KB|MB|GB|KiB|MiB|GiB)", re.ASCII | re.IGNORECASE)
_DURATION = re.compile(r"(\d+(?:\.\d+)?)\s*([smhd])", re.ASCII)
_BYTES = {"b": 1, "kb": 10**3, "mb": 10**6, "gb": 10**9, "kib": 2**10, "mib": 2**20, "gib": 2**30}
_SECONDS = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0}


@dataclass(frozen=True, slots=True)
class Split:
    """When a file is full: at ``size`` bytes, or ``seconds`` after it started (0: never)."""

    size: int = 0
    seconds: float = 0.0


def parse_split(text: str) -> Split:
    """``100MB``, ``1GiB``, ``500KB`` (a size: the unit is required) or ``30s``, ``10m``, ``1h``,
    ``1d`` (a duration); ValueError otherwise."""
    t = text.strip()
    size = _SIZE.fullmatch(t)
    if size:
        n = int(float(size.group(1)) * _BYTES[size.group(2).lower()])
        if n < 64 * 1024:
            raise ValueError(f"a split size under 64 KiB: {text!r}")
        return Split(size=n)
    duration = _DURATION.fullmatch(t)
    if duration:
        seconds = float(duration.group(1)) * _SECONDS[duration.group(2)]
        if seconds < 1.0:
            raise ValueError(f"a split duration under 1 s: {text!r}")
        return Split(seconds=seconds)
    raise ValueError(f"not a size (100MB, 1GiB) or a duration (30s, 10m, 1h): {text!r}")


def part_path(path: str, part: int) -> str:
    """The path of part ``part`` (1, 2, …) of a split recording at ``path``."""
    p = Path(path)
    suffix = p.suffix or ".mcap"
    return str(p.with_name(f"{p.stem if p.suffix else p.name}-{part:04d}{suffix}"))


class McapFile:
    """One MCAP file being written: the recording's channels, messages, chunks closed on time."""

    def __init__(self, path: str) -> None:
        self.path = path
        try:
            self._stream: BinaryIO = open(path, "wb")  # noqa: SIM115 (closed by finish)
        except OSError as exc:
            raise OSError(f"cannot write {path}: {exc.strerror or exc}") from None
        self._writer = Writer(self._stream, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile=fmt.PROFILE, library=fmt.LIBRARY)
        self._ids: dict[str, int] = {}
        w = self._writer
        for channel in fmt.CHANNELS:
            schema = w.register_schema(channel.schema_name, fmt.SCHEMA_ENCODING, channel.schema_bytes())
            self._ids[channel.topic] = w.register_channel(channel.topic, fmt.MESSAGE_ENCODING, schema)
        self.started = time.monotonic()
        self.messages = 0
        self._pending = 0  # messages not flushed yet
        self._oldest = 0.0  # when the oldest of them was written (monotonic)

    def write(self, channel: Channel, body: dict[str, object], log_time_ns: int) -> None:
        if not self._pending:
            self._oldest = time.monotonic()
        self.messages += 1
        self._pending += 1
        data = fmt.encode(body)
        self._writer.add_message(self._ids[channel.topic], log_time_ns, data, log_time_ns, self.messages)

    def due(self) -> float | None:
        """Seconds until the pending messages must be flushed (None: nothing pending)."""
        if not self._pending:
            return None
        return max(0.0, self._oldest + FLUSH_S - time.monotonic())

    def flush(self) -> None:
        """Close the open chunk and hand its bytes to the OS: they survive a kill of this process."""
        if self._pending:
            self._writer.flush()  # type: ignore[no-untyped-call]
            self._pending = 0

    def size(self) -> int:
        return self._stream.tell()

    def full(self, split: Split) -> bool:
        """Whether this file reached ``split``'s size or age."""
        if split.size and self.size() >= split.size:
            return True
        return bool(split.seconds) and time.monotonic() - self.started >= split.seconds

    def finish(self) -> None:
        """Write the last chunk, the summary and the footer, and close the file."""
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._stream.close()
