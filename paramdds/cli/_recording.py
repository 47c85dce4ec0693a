"""Reading a recording for ``history --from`` and ``diff --from``: the file read once, a torn tail noted."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from ._extras import require_extra

if TYPE_CHECKING:
    from ..formats.recording import Recording


def open_recording(path: str) -> Recording:
    """The recording at ``path`` (UsageError, exit 2: no mcap package, or not a recording). A
    file cut short by a killed recorder is read up to the tear, with one line on stderr."""
    require_extra("--from", "foxglove", ("mcap",))
    from ..formats.recording import read_recording

    recording = read_recording(path)
    if recording.torn:
        sys.stderr.write(f"paramdds: note: {recording.torn}\n")
        sys.stderr.flush()
    return recording
