"""Reading a recording for ``history --from`` and ``diff --from``: the file read once, a torn tail noted."""

from __future__ import annotations

import importlib.util
import sys
from typing import TYPE_CHECKING

from ..exits import UsageError

if TYPE_CHECKING:
    from ..formats.recording import Recording


def open_recording(path: str) -> Recording:
    """The recording at ``path`` (UsageError, exit 2: no mcap package, or not a recording). A
    file cut short by a killed recorder is read up to the tear, with one line on stderr."""
    if importlib.util.find_spec("mcap") is None:
        raise UsageError("--from needs the mcap package (the foxglove extra): pip install -e '.[foxglove]'")
    from ..formats.recording import read_recording

    recording = read_recording(path)
    if recording.torn:
        sys.stderr.write(f"paramdds: note: {recording.torn}\n")
        sys.stderr.flush()
    return recording
