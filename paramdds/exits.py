"""Exit codes of the ``paramdds`` command and the one place errors are mapped to them.

=====  ==========================================================================
code   when
=====  ==========================================================================
0      everything asked for succeeded
1      the node answered and refused or lacked something (validation, read-only,
       type, unknown parameter, compare-and-set conflict, a failed parameter of a
       non-atomic set, history it keeps none of or retention dropped); ``diff``:
       the two sides differ
2      usage error or bad local input (unknown flag, unparsable value, unreadable
       or invalid YAML with file and line)
3      node not present, or no answer within the timeout; over Zenoh, an answer that
       lacks a site (its gateway unreachable, or it did not answer in time)
4      a failure, not an answer: DDS failed in this process (participant,
       entity, write), or the node or this program hit an internal error
5      outcome unknown: a write was sent and no answer came in time; it may
       have been applied (the node refuses it past its deadline, so a ``get``
       now shows the final outcome)
130    interrupted by Ctrl-C
=====  ==========================================================================

Errors are mapped by their :class:`~paramdds.errors.ErrorCode`, never by message text.
"""

from __future__ import annotations

import sys
from enum import IntEnum

from .errors import ErrorCode, ParamddsError


class Exit(IntEnum):
    OK = 0
    REFUSED = 1
    USAGE = 2
    UNREACHABLE = 3
    FAILURE = 4
    OUTCOME_UNKNOWN = 5
    INTERRUPTED = 130


class UsageError(Exception):
    """Bad command-line usage or bad local input: exit 2."""


class Refused(Exception):
    """The node answered and refused something; already reported in detail: exit 1."""


class Terminated(Exception):
    """Raised in the main thread by the SIGTERM handler: a graceful stop, exit 0."""


_UNREACHABLE = {ErrorCode.TIMEOUT, ErrorCode.UNAVAILABLE}
_LOCAL = {ErrorCode.FILE_FORMAT}
_FAILURE = {ErrorCode.INTERNAL}


def is_dds_failure(exc: BaseException) -> bool:
    """Whether ``exc`` is Cyclone's own exception (a local DDS failure)."""
    core = sys.modules.get("cyclonedds.core")
    return core is not None and isinstance(exc, core.DDSException)


def exit_code(exc: BaseException) -> Exit:
    """The exit code for an exception that ended a verb."""
    if isinstance(exc, KeyboardInterrupt):
        return Exit.INTERRUPTED
    if isinstance(exc, Terminated):
        return Exit.OK
    if isinstance(exc, UsageError):
        return Exit.USAGE
    if isinstance(exc, ParamddsError):
        if exc.code in _UNREACHABLE:
            return Exit.UNREACHABLE
        if exc.code in _LOCAL:
            return Exit.USAGE
        if exc.code in _FAILURE:
            return Exit.FAILURE
        if exc.code is ErrorCode.OUTCOME_UNKNOWN:
            return Exit.OUTCOME_UNKNOWN
        return Exit.REFUSED
    return Exit.FAILURE  # a DDSException, or a bug of ours


def one_line(text: str) -> str:
    """``text`` folded onto one line (errors are one line on stderr)."""
    return "; ".join(part.strip() for part in str(text).splitlines() if part.strip())
