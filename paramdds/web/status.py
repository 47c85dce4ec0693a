"""The one table from error codes to HTTP statuses, and the JSON body of an error.

Every error the API returns is ``{"error": {"code": CODE, "message": TEXT}}`` with
the status :data:`STATUS` gives for ``CODE``. The codes are those of
:class:`paramdds.errors.ErrorCode` plus a few that only HTTP has (:class:`WebCode`).
A status is never decided from message text.
"""

from __future__ import annotations

from enum import Enum

from ..errors import ErrorCode, ParamddsError


class WebCode(str, Enum):
    """Failures that exist only at the HTTP boundary."""

    BAD_REQUEST = "BAD_REQUEST"  # not JSON, or not the shape a route expects
    UNAUTHORIZED = "UNAUTHORIZED"  # a write without the bearer token
    CROSS_ORIGIN = "CROSS_ORIGIN"  # a write from a page of another origin
    UNSUPPORTED_MEDIA = "UNSUPPORTED_MEDIA"  # a write whose body is not application/json


STATUS: dict[str, int] = {
    ErrorCode.NOT_FOUND: 404,
    ErrorCode.READ_ONLY: 403,
    ErrorCode.TYPE_MISMATCH: 422,
    ErrorCode.OUT_OF_RANGE: 422,
    ErrorCode.INVALID_VALUE: 422,
    ErrorCode.INVALID_NAME: 422,
    ErrorCode.FILE_FORMAT: 422,
    ErrorCode.ALREADY_DECLARED: 409,
    ErrorCode.CONFLICT: 409,
    ErrorCode.IN_CALLBACK: 409,
    ErrorCode.TOO_LARGE: 413,
    ErrorCode.NOT_PERSISTED: 507,  # applied, but not stored: the server's disk refused
    ErrorCode.UNAVAILABLE: 503,
    ErrorCode.TIMEOUT: 504,
    ErrorCode.OUTCOME_UNKNOWN: 504,  # a write sent, no answer in time: it may have been applied
    ErrorCode.EXPIRED: 409,  # refused: past its deadline at the node, nothing applied
    ErrorCode.NOT_PERMITTED: 403,  # secure mode: DDS Security refuses this identity the action
    ErrorCode.INTERNAL: 500,  # the node (or this console) failed: not a refusal of the value
    ErrorCode.UNKNOWN: 502,  # the node answered with a code this version does not know
    ErrorCode.NO_HISTORY: 404,  # the node keeps no history (/api/history answers "kept": false instead)
    WebCode.BAD_REQUEST: 400,
    WebCode.UNAUTHORIZED: 401,
    WebCode.CROSS_ORIGIN: 403,
    WebCode.UNSUPPORTED_MEDIA: 415,
}


def status_of(code: str) -> int:
    """The HTTP status for an error code (500 only for a code this table lacks)."""
    return STATUS.get(code, 500)


class WebError(ParamddsError):
    """An error raised by the web layer itself, with a :class:`WebCode` or an :class:`ErrorCode`."""

    def __init__(self, code: WebCode | ErrorCode, message: str) -> None:
        super().__init__(message)
        self.web_code = code

    @property
    def code_text(self) -> str:
        return str(self.web_code.value)


def error_body(code: str, message: str) -> dict[str, object]:
    return {"error": {"code": code, "message": message}}


def code_of(exc: ParamddsError) -> str:
    """The code an exception carries, as text."""
    if isinstance(exc, WebError):
        return exc.code_text
    return str(ErrorCode(exc.code).value)
