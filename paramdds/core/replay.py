"""The seam between a node's history and its live changes: each change once, in revision order.

``watch --since REV`` reads the node's changes after ``REV`` from its history while a
monitor already sees live changes; the two overlap, and a live reader may miss a change
(state samples are keyed per parameter, so a slow reader keeps only a parameter's newest
value, and nothing in a sample says how many parameters its revision changed). So a
live change is a signal, not an item: :meth:`Seam.live` says when the node has moved
past what was delivered, the caller asks history for the changes after :attr:`Seam.top`,
and :meth:`Seam.history` delivers those not delivered yet, whole revisions, in order.
A revision history lacks (retention dropped it) is a :class:`Gap` in the stream; a live
revision history never reaches (the node lost it) is given up with :meth:`Seam.skip`,
a :class:`Gap` too. Nothing is missed silently, nothing is delivered twice.

Pure and not thread-safe: the caller feeds it from one thread.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Generic, TypeVar

__all__ = ["Gap", "Seam"]

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Gap:
    """Revisions after ``after`` and before ``before`` were never delivered: lost."""

    after: int
    before: int


@dataclass(slots=True)
class Seam(Generic[T]):
    """One node's history pages and live revisions (within one incarnation) merged into one stream.

    ``top`` is the highest revision delivered (every change up to it delivered, or inside
    a reported gap); ``ahead`` the highest revision seen live above it (None: none).
    """

    top: int
    ahead: int | None = None

    def live(self, revision: int) -> bool:
        """A live reader saw a change at ``revision``: True when history must be asked for
        the changes after :attr:`top` (the node moved past what was delivered)."""
        if revision <= self.top:
            return False  # delivered already (or older: a parameter's state, not a change)
        self.ahead = revision if self.ahead is None else max(self.ahead, revision)
        return True

    @property
    def wanted(self) -> bool:
        """Whether a live revision is still waiting for history."""
        return self.ahead is not None

    def history(self, changes: Iterable[tuple[int, T]]) -> list[T | Gap]:
        """Changes read from history after some revision (``(revision, item)``, whole
        revisions): those after :attr:`top`, in order, a :class:`Gap` where history skips."""
        out: list[T | Gap] = []
        last = self.top
        for revision, item in sorted(changes, key=lambda c: c[0]):
            if revision <= self.top:
                continue  # delivered already: a revision comes whole from history
            if revision > last + 1:
                out.append(Gap(last, revision))
            out.append(item)
            last = revision
        self.top = last
        if self.ahead is not None and self.ahead <= self.top:
            self.ahead = None
        return out

    def skip(self) -> list[T | Gap]:
        """History does not reach the live revision :attr:`ahead`: report the revisions up to
        it as lost (a :class:`Gap`), and go on from there."""
        if self.ahead is None:
            return []
        gap = Gap(self.top, self.ahead + 1)
        self.top, self.ahead = self.ahead, None
        return [gap]

    def reset(self, revision: int = 0) -> None:
        """A new incarnation (the node's server started again): revisions start again after ``revision``."""
        self.top, self.ahead = revision, None
