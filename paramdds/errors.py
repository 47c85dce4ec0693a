"""The one exception tree of paramdds.

Every failure a user can meet is a :class:`ParamddsError` with a machine-readable
``code`` (an :class:`ErrorCode`), so the CLI, the Python API and any future web layer
map errors without matching on message text::

    ParamddsError                      code
    ├── ParameterError                 the node's rules refused something
    │   ├── NotFoundError              NOT_FOUND (unknown parameter or node)
    │   ├── ReadOnlyError              READ_ONLY
    │   ├── TypeMismatchError          TYPE_MISMATCH
    │   ├── OutOfRangeError            OUT_OF_RANGE
    │   ├── InvalidValueError          INVALID_VALUE
    │   ├── InvalidNameError           INVALID_NAME
    │   ├── AlreadyDeclaredError       ALREADY_DECLARED
    │   ├── ConflictError              CONFLICT (compare-and-set lost)
    │   └── CallbackError              IN_CALLBACK (parameters changed from a callback)
    ├── FileFormatError                FILE_FORMAT (YAML file; carries file and line)
    ├── TooLargeError                  TOO_LARGE (a request or value over our limits)
    ├── NotPersistedError              NOT_PERSISTED (applied, but not written to --persist)
    ├── InternalError                  INTERNAL (a bug on the node's side, reported to the caller)
    ├── NotPermittedError              NOT_PERMITTED (secure mode: DDS Security refused the action)
    ├── ExpiredError                   EXPIRED (a write refused: it reached its commit point past its
    │                                  deadline; nothing applied)
    ├── OutcomeUnknownError            OUTCOME_UNKNOWN (a write sent and not answered in time: it may
    │                                  have been applied; never a failure, see docs/reliability.md)
    ├── RemoteError                    UNKNOWN (a code this version does not know; ``remote_code``)
    └── TransportError                 the node could not be reached
        ├── CallTimeoutError           TIMEOUT (no answer within the timeout)
        └── UnavailableError           UNAVAILABLE (the node is not present)

Lower-level errors (PyYAML, Cyclone) are mapped to these at exactly one boundary,
with ``raise … from``.
"""

from __future__ import annotations

from enum import Enum


class ErrorCode(str, Enum):
    NOT_FOUND = "NOT_FOUND"
    READ_ONLY = "READ_ONLY"
    TYPE_MISMATCH = "TYPE_MISMATCH"
    OUT_OF_RANGE = "OUT_OF_RANGE"
    INVALID_VALUE = "INVALID_VALUE"
    INVALID_NAME = "INVALID_NAME"
    ALREADY_DECLARED = "ALREADY_DECLARED"
    CONFLICT = "CONFLICT"
    IN_CALLBACK = "IN_CALLBACK"
    FILE_FORMAT = "FILE_FORMAT"
    TOO_LARGE = "TOO_LARGE"
    TIMEOUT = "TIMEOUT"
    UNAVAILABLE = "UNAVAILABLE"
    NOT_PERSISTED = "NOT_PERSISTED"
    INTERNAL = "INTERNAL"
    NOT_PERMITTED = "NOT_PERMITTED"  # secure mode: DDS Security refused this identity the action
    UNKNOWN = "UNKNOWN"  # a code this version does not know (a newer node's): see RemoteError
    EXPIRED = "EXPIRED"  # a write refused whole: past its deadline at the node's commit point
    OUTCOME_UNKNOWN = "OUTCOME_UNKNOWN"  # a write sent and not answered in time: applied or not
    NO_HISTORY = "NO_HISTORY"  # the node keeps no history (a peer that does not record it)


class ParamddsError(Exception):
    """Base of every error paramdds raises on purpose."""

    code: ErrorCode = ErrorCode.INVALID_VALUE

    def __init__(self, message: str, *, code: ErrorCode | None = None) -> None:
        super().__init__(message)
        self.message = message
        if code is not None:
            self.code = code


class ParameterError(ParamddsError):
    """A node's rules refused a request (the node itself is fine)."""


class NotFoundError(ParameterError):
    code = ErrorCode.NOT_FOUND


class ReadOnlyError(ParameterError):
    code = ErrorCode.READ_ONLY


class TypeMismatchError(ParameterError):
    code = ErrorCode.TYPE_MISMATCH


class OutOfRangeError(ParameterError):
    code = ErrorCode.OUT_OF_RANGE


class InvalidValueError(ParameterError):
    code = ErrorCode.INVALID_VALUE


class InvalidNameError(ParameterError):
    code = ErrorCode.INVALID_NAME


class AlreadyDeclaredError(ParameterError):
    code = ErrorCode.ALREADY_DECLARED


class ConflictError(ParameterError):
    code = ErrorCode.CONFLICT


class CallbackError(ParameterError):
    code = ErrorCode.IN_CALLBACK


class NoHistoryError(ParamddsError):
    """The node answered, and keeps no history (a peer built without it)."""

    code = ErrorCode.NO_HISTORY


class FileFormatError(ParamddsError):
    """A parameter file could not be used. ``str()`` reads ``file:line: message``."""

    code = ErrorCode.FILE_FORMAT

    def __init__(self, message: str, *, file: str | None = None, line: int | None = None) -> None:
        self.file = file
        self.line = line
        where = file or "<string>"
        if line is not None:
            where = f"{where}:{line}"
        super().__init__(f"{where}: {message}")
        self.detail = message


class TooLargeError(ParamddsError):
    code = ErrorCode.TOO_LARGE


class NotPersistedError(ParamddsError):
    """The change was applied (and published), but the server could not write it to its
    persistence file: it holds until the server restarts, and is lost then."""

    code = ErrorCode.NOT_PERSISTED


class InternalError(ParamddsError):
    """The node failed while handling the request (a bug there); the request may not be applied."""

    code = ErrorCode.INTERNAL


class NotPermittedError(ParamddsError):
    """Secure mode: DDS Security does not let this identity do that (its role or node grants)."""

    code = ErrorCode.NOT_PERMITTED


class ExpiredError(ParamddsError):
    """A write refused whole by the node: it reached the node's commit point after its
    deadline (by the node's clock). Nothing was applied, and it never will be."""

    code = ErrorCode.EXPIRED


class OutcomeUnknownError(ParamddsError):
    """A write was sent but no answer came in time: it may or may not have been applied.

    Not a failure (and deliberately not a :class:`TransportError`): a node sees the
    request's deadline and never applies it after that by its own clock, so a ``get``
    once the error is raised shows the final outcome (docs/reliability.md gives the
    limits when the two hosts' clocks differ)."""

    code = ErrorCode.OUTCOME_UNKNOWN


class RemoteError(ParamddsError):
    """The node answered with an error code this version does not know (a newer node):
    ``remote_code`` is the code as sent."""

    code = ErrorCode.UNKNOWN

    def __init__(self, message: str, *, remote_code: str) -> None:
        super().__init__(f"{message} [{remote_code}]")
        self.remote_code = remote_code


class TransportError(ParamddsError):
    """The node could not be reached."""


class CallTimeoutError(TransportError):
    """No answer came within the call's timeout (the node may be slow, or gone)."""

    code = ErrorCode.TIMEOUT


TimeoutError_ = CallTimeoutError  # the name of 0.1.0's first releases, kept for their users


class UnavailableError(TransportError):
    code = ErrorCode.UNAVAILABLE


_BY_CODE: dict[ErrorCode, type[ParamddsError]] = {
    cls.code: cls
    for cls in (
        NotFoundError,
        ReadOnlyError,
        TypeMismatchError,
        OutOfRangeError,
        InvalidValueError,
        InvalidNameError,
        AlreadyDeclaredError,
        ConflictError,
        CallbackError,
        FileFormatError,
        TooLargeError,
        NotPersistedError,
        InternalError,
        NotPermittedError,
        ExpiredError,
        OutcomeUnknownError,
        CallTimeoutError,
        UnavailableError,
    )
}


def error_for(code: ErrorCode | str, message: str) -> ParamddsError:
    """The exception a remote ``code`` stands for (used where a reply carries a code)."""
    known = code_of(str(code.value if isinstance(code, ErrorCode) else code))
    if known is ErrorCode.UNKNOWN or known is None:
        return RemoteError(message, remote_code=str(code))
    cls = _BY_CODE.get(known)
    if cls is None:
        return ParamddsError(message, code=known)
    if cls is FileFormatError:
        return FileFormatError(message)
    return cls(message)


def code_of(text: str) -> ErrorCode | None:
    """The ErrorCode a reply's code string stands for: None for "", UNKNOWN for one this
    version does not know (an older client must keep working against a newer node)."""
    if not text:
        return None
    try:
        return ErrorCode(text)
    except ValueError:
        return ErrorCode.UNKNOWN
