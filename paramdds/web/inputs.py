"""Reading what a request carries: query arguments, a JSON body with a size cap, an uploaded file.

Every problem is a :class:`~paramdds.web.status.WebError` (BAD_REQUEST, TOO_LARGE,
UNSUPPORTED_MEDIA) or the core's own error (INVALID_NAME, FILE_FORMAT), never a 500.
"""

from __future__ import annotations

import json
from datetime import datetime, timezone
from typing import Any

from starlette.requests import Request

from ..core.descriptors import ParameterDescriptor
from ..core.history import Outcome
from ..core.names import canonical_node_id, validate_name
from ..core.revision import Revision
from ..core.values import ParameterValue
from ..errors import ErrorCode, ParamddsError
from .status import WebCode, WebError

MAX_BODY = 1024 * 1024  # bytes
LAST_TIME = (2**63 - 1) / 1e9  # seconds since the epoch: a time the wire carries (int64 nanoseconds)


def node_arg(raw: object) -> str:
    if not isinstance(raw, str) or not raw:
        raise WebError(WebCode.BAD_REQUEST, "'node' must be a non-empty string")
    return canonical_node_id(raw)


def int_arg(request: Request, name: str, default: int, lo: int, hi: int) -> int:
    text = request.query_params.get(name)
    if text is None:
        return default
    try:
        value = int(text)
    except ValueError:
        raise WebError(WebCode.BAD_REQUEST, f"{name!r} must be an integer, got {text[:40]!r}") from None
    if not lo <= value <= hi:
        raise WebError(WebCode.BAD_REQUEST, f"{name!r} must be within [{lo}, {hi}], got {value}")
    return value


async def read_body(request: Request) -> dict[str, Any]:
    """The JSON object of a write, read with a size cap."""
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if ctype != "application/json":
        raise WebError(WebCode.UNSUPPORTED_MEDIA, "a write needs Content-Type: application/json")
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > MAX_BODY:
        raise WebError(ErrorCode.TOO_LARGE, f"the body is {declared} bytes; the limit is {MAX_BODY}")
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > MAX_BODY:
            raise WebError(ErrorCode.TOO_LARGE, f"the body is over the limit of {MAX_BODY} bytes")
    try:
        body = json.loads(data)
    except (ValueError, RecursionError) as exc:
        raise WebError(WebCode.BAD_REQUEST, f"the body is not valid JSON: {exc}") from None
    if not isinstance(body, dict):
        raise WebError(WebCode.BAD_REQUEST, "the body must be a JSON object")
    return body


def bool_field(body: dict[str, Any], name: str) -> bool:
    value = body.get(name, False)
    if not isinstance(value, bool):
        raise WebError(WebCode.BAD_REQUEST, f"{name!r} must be true or false")
    return value


def revision_field(body: dict[str, Any]) -> int | Revision | None:
    """``if_revision``: null, ``"INCARNATION:REVISION"`` (a summary's ``incarnation`` and
    ``revision``: compares both), or a bare revision number (compares it alone)."""
    value = body.get("if_revision")
    if value is None:
        return None
    if isinstance(value, str):
        try:
            return Revision.parse(value)
        except ParamddsError as exc:
            raise WebError(WebCode.BAD_REQUEST, f"'if_revision': {exc.message}") from None
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**63:
        raise WebError(
            WebCode.BAD_REQUEST,
            "'if_revision' must be null, \"INCARNATION:REVISION\" or a revision from 0 to 2**63-1",
        )
    return value


def file_entries(text: str, node: str) -> list[tuple[str, ParameterValue, ParameterDescriptor | None]]:
    """The entries an uploaded parameter file gives ``node`` (either format, as ``paramdds load``)."""
    from ..formats.files import is_param_list, parse_ros_text

    source = "upload"
    if is_param_list(text, source):
        from ..formats.paramlist import load_param_list_str

        return [(p.name, p.value, None) for p in load_param_list_str(text, source=source)]
    return parse_ros_text(text, source, node)


def since_arg(request: Request) -> tuple[int | None, datetime | None]:
    """``since``: a revision (the records after it) or an ISO 8601 time (the records at or after
    it); (revision, time), at most one of them given."""
    text = request.query_params.get("since")
    if text is None or not text.strip():
        return None, None
    if text.strip().isdigit():
        return int(text), None
    return None, _iso_time("since", text, "a revision or ")


def time_arg(request: Request, name: str) -> datetime | None:
    """An ISO 8601 time (``2026-11-29T14:32:00Z``; one without a zone is UTC), or None when absent."""
    text = request.query_params.get(name)
    return _iso_time(name, text) if text is not None and text.strip() else None


def _iso_time(name: str, text: str, other: str = "") -> datetime:
    try:
        moment = datetime.fromisoformat(text.strip())
    except ValueError:
        raise WebError(
            WebCode.BAD_REQUEST,
            f"{name!r} must be {other}an ISO 8601 time such as 2026-11-29T14:32:00Z, got {text[:40]!r}",
        ) from None
    moment = moment if moment.tzinfo is not None else moment.replace(tzinfo=timezone.utc)
    if not 0 <= moment.timestamp() < LAST_TIME:
        raise WebError(WebCode.BAD_REQUEST, f"{name!r} must be a time from 1970 to 2262, got {text[:40]!r}")
    return moment


def names_arg(request: Request) -> tuple[str, ...]:
    """Every ``name`` argument, each a valid parameter name (INVALID_NAME otherwise)."""
    names = tuple(dict.fromkeys(request.query_params.getlist("name")))
    for n in names:
        validate_name(n)
    return names


OUTCOMES = {"all": Outcome.ALL, "applied": Outcome.APPLIED, "refused": Outcome.REFUSED}


def outcome_arg(request: Request) -> Outcome:
    text = request.query_params.get("outcome", "all")
    if text not in OUTCOMES:
        shown = ", ".join(OUTCOMES)
        raise WebError(WebCode.BAD_REQUEST, f"'outcome' must be one of {shown}, got {text[:40]!r}")
    return OUTCOMES[text]
