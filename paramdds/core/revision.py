"""A node's state, exactly: (incarnation, revision). Pure, no DDS (the CLI parses it early)."""

from __future__ import annotations

from typing import NamedTuple

from ..errors import ParamddsError

__all__ = ["Revision", "incarnation_text"]


def incarnation_text(incarnation: int) -> str:
    """An incarnation as it is written everywhere: 16 hex digits (a JSON number would lose
    digits above 2**53 in a browser)."""
    return f"{incarnation:016x}"


class Revision(NamedTuple):
    """A node's state exactly: its revision within one incarnation (one start of hosting it).

    A revision alone repeats across a server restart; this pair does not. Give one to
    ``set(..., if_revision=)`` to compare both; a plain ``int`` there compares the
    revision alone. Written ``INCARNATION:REVISION``, the incarnation in 16 hex digits
    (``paramdds set --if-revision``, the JSON outputs and the web API use that form).
    """

    incarnation: int  # random, non-zero; 0: unknown (a peer that has none)
    revision: int

    def __str__(self) -> str:
        return f"{incarnation_text(self.incarnation)}:{self.revision}"

    @classmethod
    def parse(cls, text: str) -> Revision:
        """``INCARNATION:REVISION`` (hex, decimal) or a bare revision (incarnation 0)."""
        head, sep, tail = text.strip().rpartition(":")
        try:
            incarnation = int(head, 16) if sep else 0
            revision = int(tail, 10)
        except ValueError:
            raise ParamddsError(f"not a revision (REVISION or INCARNATION:REVISION): {text!r}") from None
        parsed = cls(incarnation, revision)
        if not parsed.on_wire():
            raise ParamddsError(f"revision out of range: {text!r}")
        return parsed

    def on_wire(self) -> bool:
        """Whether a set request can carry it (a uint64 incarnation, a non-negative int64 revision)."""
        return 0 <= self.incarnation < 2**64 and 0 <= self.revision < 2**63
