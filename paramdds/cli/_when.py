"""Points in a node's past on the command line: ``--since REV|TIME``, ``--until TIME``, ``NODE@REV|TIME``.

A revision is a non-negative integer. A time is ISO 8601 (``2026-11-29T14:32:00Z``,
``2026-11-29 14:32``, ``2026-11-29``; without an offset it is UTC, as ``history``
prints it) or an age, that long before now: ``90s``, ``10m``, ``2h``, ``3d``, ``1w``.
Anything else is a usage error (exit 2), one line.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from datetime import datetime, timezone

from ..exits import UsageError

_AGE = re.compile(r"(\d+(?:\.\d+)?)\s*([smhdw])", re.ASCII)
_UNIT = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0, "w": 7 * 86400.0}
_FORMS = "a revision (an integer), an ISO 8601 time (2026-11-29T14:32:00Z) or an age (10m, 2h, 3d)"


@dataclass(frozen=True, slots=True)
class Point:
    """A point in a node's past: after a revision, or at a time (seconds since the epoch)."""

    revision: int | None = None
    time_s: float | None = None

    def __str__(self) -> str:
        if self.revision is not None:
            return f"revision {self.revision}"
        return f"{datetime.fromtimestamp(self.time_s or 0.0, tz=timezone.utc):%Y-%m-%dT%H:%M:%SZ}"


def parse_time(text: str, *, option: str = "--until", now: float | None = None) -> float:
    """A time or an age as seconds since the epoch (UsageError when it is neither)."""
    t = text.strip()
    age = _AGE.fullmatch(t)
    if age:
        return (time.time() if now is None else now) - float(age.group(1)) * _UNIT[age.group(2)]
    try:
        moment = datetime.fromisoformat(t)
    except ValueError:
        raise UsageError(
            f"{option}: not a time: {text!r} (ISO 8601, like 2026-11-29T14:32:00Z, or an age: 10m, 2h, 3d)"
        ) from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    return moment.timestamp()


def parse_point(text: str, *, option: str = "--since", now: float | None = None) -> Point:
    """A revision (an integer) or a time (see :func:`parse_time`)."""
    t = text.strip()
    if re.fullmatch(r"[0-9]+", t):
        revision = int(t)
        if revision >= 2**63:
            raise UsageError(f"{option}: revision out of range: {text!r}")
        return Point(revision=revision)
    if not t or re.fullmatch(r"-[0-9]+", t):
        raise UsageError(f"{option}: not {_FORMS}: {text!r}")
    try:
        return Point(time_s=parse_time(t, option=option, now=now))
    except UsageError:
        raise UsageError(f"{option}: not {_FORMS}: {text!r}") from None


def split_at(text: str) -> tuple[str, Point | None]:
    """``NODE@REV`` or ``NODE@TIME`` as the node and the point; ``NODE`` alone as (NODE, None)."""
    node, sep, when = text.partition("@")
    if not sep:
        return text, None
    if not node:
        raise UsageError(f"{text!r}: no node before '@' (NODE@REV or NODE@TIME)")
    return node, parse_point(when, option=f"{node}@")
