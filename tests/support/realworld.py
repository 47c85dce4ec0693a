"""Where the real parameter files (``shared/realworld``: nav2, Autoware, controllers) are."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the checkout


def find_realworld() -> Path | None:
    """The real parameter files: ``$PARAMDDS_REALWORLD``, else ``shared/realworld`` beside the
    checkout (``../shared``) or beside the directory of worktrees (``../../shared``)."""
    given = os.environ.get("PARAMDDS_REALWORLD")
    for candidate in (
        [Path(given)]
        if given
        else [ROOT.parent / "shared" / "realworld", ROOT.parent.parent / "shared" / "realworld"]
    ):
        if candidate.is_dir():
            return candidate
    return None
