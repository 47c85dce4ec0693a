"""The JSON payloads of paramdds on Zenoh (UTF-8 JSON, encoding ``application/json``).

Language-neutral on purpose: any Zenoh program reads a node's state and calls a node
with a JSON library. The shapes (docs/zenoh.md repeats them):

* a value: ``{"type": "double", "value": 1.5}``; byte arrays as lists of ints, doubles
  that are not finite as ``"nan"``, ``"inf"``, ``"-inf"``, not_set ``{"type": "not_set",
  "value": null}``;
* a descriptor: ``{"type", "description", "additional_constraints", "read_only",
  "dynamic_typing", "integer_range", "floating_point_range", "validators"}``, a range
  ``{"from_value", "to_value", "step"}`` or null, a validator ``{"kind", "args": [values]}``;
* a node's state (``.../state``): ``{"v": 1, "kind": "state", "site", "node", "gateway",
  "seq", "online", "host", "pid", "revision", "incarnation" (16 hex digits), "announced",
  "origin", "parameters": {name: {"value", "descriptor", "last_change"}}}``, a last change
  ``{"who", "verified", "via", "time" (ISO 8601 UTC), "revision"}`` (who last
  changed the parameter, as ``describe -o json`` shows it) or null when the node does not
  say (an older node); ``seq`` counts the
  gateway's publications of that node (a receiver keeps the highest per gateway). A query
  is always answered with whole states; a publication is a whole state the first time a
  gateway publishes a node, then a ``"kind": "delta"`` with ``"base"`` (the seq it follows)
  and ``"deleted": [names]``, whose ``parameters`` hold only what changed: a receiver
  that does not hold exactly ``base`` of that gateway asks for the node's state instead;
* requests: get ``{"names": [...], "with_descriptors": bool, "timeout": s}``, list
  ``{"prefixes": [...], "depth": n, "timeout": s}``, set ``{"parameters": [{"name",
  "value"}], "atomic": bool, "if_revision": "INCARNATION:REVISION" | n | null, "who": claim,
  "timeout": s}`` (a not_set value deletes; ``who``: who asks, recorded by the node with
  via ``zenoh``, unverified); history: :mod:`.history`;
* replies: ``{"ok": true, "node", "revision", "incarnation", "results": [...]}`` (get:
  ``{"name", "value", "descriptor", "code", "reason", "last_change"}``, the last change
  with the descriptor when the node says it, else null; set: ``{"name", "successful",
  "reason", "code"}``), list ``{"ok": true, "names", "prefixes"}``, or an error
  ``{"ok": false, "code": "UNAVAILABLE", "message": "..."}``.

Values and descriptors take the tagged form of :mod:`paramdds.core.jsonform` (the one mapping
the CLI, the console and the journal share). Pure: no Zenoh, no DDS.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any

from ..core.descriptors import ParameterDescriptor
from ..core.jsonform import descriptor_of_json, json_descriptor, json_tagged_value, value_of_tagged
from ..core.results import GetResult, LastChange, SetResult
from ..core.revision import Revision, incarnation_text
from ..core.values import Parameter, ParameterValue
from ..errors import ErrorCode, FileFormatError, ParamddsError, TooLargeError, code_of, error_for

VERSION = 1
MAX_PAYLOAD = 16 * 1024 * 1024  # bytes: a reply or state larger than this is refused (TOO_LARGE)
ENCODING = "application/json"

# -- values and descriptors: the tagged form of paramdds.core.jsonform -----------------------------

value_out = json_tagged_value
value_in = value_of_tagged
descriptor_in = descriptor_of_json


def descriptor_out(d: ParameterDescriptor) -> dict[str, object]:
    """A descriptor in the tagged form (:func:`paramdds.core.jsonform.json_descriptor`)."""
    return json_descriptor(d, tagged=True)


# -- blame: who last changed a parameter -----------------------------------------------------


def time_ns_of(obj: Mapping[str, Any]) -> int:
    """``time_ns`` when given (exact), else the ISO ``time`` (microseconds)."""
    if obj.get("time_ns") is not None:
        return int(obj["time_ns"])
    text = str(obj["time"])
    moment = datetime.strptime(text.rstrip("Z"), "%Y-%m-%dT%H:%M:%S.%f").replace(tzinfo=timezone.utc)
    return int(moment.timestamp()) * 1_000_000_000 + moment.microsecond * 1000


def last_change_out(lc: LastChange | None) -> dict[str, object] | None:
    """``{"who", "verified", "via", "time", "revision"}``, what ``describe -o json`` prints
    (the time to the microsecond: every parameter of every state carries one, and a
    ``time_ns`` beside it cost 30 bytes more each); None for an unknown one."""
    return None if lc is None else lc.to_json()


def last_change_in(obj: object) -> LastChange | None:
    """A last change from its JSON (null: unknown); FileFormatError for a malformed one."""
    if obj is None:
        return None
    try:
        if not isinstance(obj, Mapping):
            raise TypeError(f"not an object: {str(obj)[:60]}")
        return LastChange(
            str(obj["who"]), bool(obj["verified"]), str(obj["via"]), time_ns_of(obj), int(obj["revision"])
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise FileFormatError(f"a malformed last change: {type(exc).__name__}: {exc}") from None


# -- whole payloads ------------------------------------------------------------------------------


def dumps(obj: object) -> bytes:
    return json.dumps(obj, ensure_ascii=False, allow_nan=False, separators=(",", ":")).encode()


def loads(data: bytes, what: str) -> dict[str, Any]:
    """A JSON object from a payload: TOO_LARGE over :data:`MAX_PAYLOAD`, else a clear error."""
    if len(data) > MAX_PAYLOAD:
        raise TooLargeError(f"{what}: {len(data)} bytes exceed the limit of {MAX_PAYLOAD}")
    try:
        obj = json.loads(data)
    except (ValueError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{what} is not JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise FileFormatError(f"{what} is not a JSON object")
    return obj


@dataclass
class NodeStateMsg:
    """One node's state as a gateway publishes it and answers a state query."""

    site: str
    node: str
    gateway: str
    seq: int
    online: bool
    host: str = ""
    pid: int = 0
    revision: int = 0
    incarnation: int = 0
    announced: int = -1
    origin: str | None = None
    parameters: dict[str, tuple[ParameterValue, ParameterDescriptor]] = field(default_factory=dict)
    kind: str = "state"  # "delta": parameters holds only what changed since seq ``base``
    base: int = 0
    deleted: list[str] = field(default_factory=list)
    status: str | None = None  # "unreachable", "stale" (a ROS 2 mirror: NodeState.status), else None
    last_changes: dict[str, LastChange] = field(default_factory=dict)  # blame, of the parameters that say it

    def encode(self) -> bytes:
        extra: dict[str, object] = {}
        if self.kind == "delta":
            extra = {"base": self.base, "deleted": sorted(self.deleted)}
        return dumps(
            {
                "v": VERSION,
                "kind": self.kind,
                **extra,
                "site": self.site,
                "node": self.node,
                "gateway": self.gateway,
                "seq": self.seq,
                "online": self.online,
                "host": self.host,
                "pid": self.pid,
                "revision": self.revision,
                "incarnation": incarnation_text(self.incarnation),
                "announced": self.announced,
                "origin": self.origin,
                "status": self.status,
                "parameters": {
                    n: {
                        "value": value_out(v),
                        "descriptor": descriptor_out(d),
                        "last_change": last_change_out(self.last_changes.get(n)),
                    }
                    for n, (v, d) in sorted(self.parameters.items())
                },
            }
        )

    @classmethod
    def decode(cls, data: bytes) -> NodeStateMsg:
        obj = loads(data, "a node state")
        try:
            entries = dict(obj.get("parameters", {}))
            params = {
                str(n): (value_in(e["value"]), descriptor_in(str(n), e["descriptor"]))
                for n, e in entries.items()
            }
            blame = {str(n): last_change_in(e.get("last_change")) for n, e in entries.items()}
            return cls(
                site=str(obj["site"]),
                node=str(obj["node"]),
                gateway=str(obj["gateway"]),
                seq=int(obj["seq"]),
                online=bool(obj["online"]),
                host=str(obj.get("host", "")),
                pid=int(obj.get("pid", 0)),
                revision=int(obj.get("revision", 0)),
                incarnation=int(str(obj.get("incarnation", "0")), 16),
                announced=int(obj.get("announced", -1)),
                origin=None if obj.get("origin") is None else str(obj["origin"]),
                status=None if obj.get("status") is None else str(obj["status"]),
                parameters=params,
                kind="delta" if obj.get("kind") == "delta" else "state",
                base=int(obj.get("base", 0)),
                deleted=[str(n) for n in obj.get("deleted", [])],
                last_changes={n: lc for n, lc in blame.items() if lc is not None},
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise FileFormatError(f"a malformed node state: {type(exc).__name__}: {exc}") from None


# -- requests -----------------------------------------------------------------------------------


def get_request(names: Sequence[str], with_descriptors: bool, timeout: float) -> bytes:
    return dumps({"names": list(names), "with_descriptors": with_descriptors, "timeout": timeout})


def list_request(prefixes: Sequence[str], depth: int, timeout: float) -> bytes:
    return dumps({"prefixes": list(prefixes), "depth": depth, "timeout": timeout})


def set_request(
    params: Sequence[Parameter], atomic: bool, if_revision: int | Revision | None, timeout: float
) -> bytes:
    expected: object = None
    if isinstance(if_revision, Revision):
        expected = str(if_revision)
    elif if_revision is not None:
        expected = int(if_revision)
    return dumps(
        {
            "parameters": [{"name": p.name, "value": value_out(p.value)} for p in params],
            "atomic": atomic,
            "if_revision": expected,
            "timeout": timeout,
        }
    )


def parse_if_revision(obj: object) -> int | Revision | None:
    if obj is None:
        return None
    if isinstance(obj, int) and not isinstance(obj, bool):
        return obj
    if isinstance(obj, str):
        return Revision.parse(obj)
    raise ParamddsError(f"if_revision must be null, an integer or 'INCARNATION:REVISION', got {obj!r}")


def parse_parameters(obj: object) -> list[Parameter]:
    if not isinstance(obj, list):
        raise ParamddsError("'parameters' must be a list of {name, value}")
    return [Parameter(str(e["name"]), value_in(e["value"])) for e in obj]


# -- replies ------------------------------------------------------------------------------------


def error_reply(exc: ParamddsError) -> bytes:
    return dumps({"ok": False, "code": exc.code.value, "message": exc.message})


def _code_text(code: ErrorCode | None) -> str | None:
    return None if code is None else code.value


def get_reply(node: str, revision: int, incarnation: int, results: Sequence[GetResult]) -> bytes:
    return dumps(
        {
            "ok": True,
            "node": node,
            "revision": revision,
            "incarnation": incarnation_text(incarnation),
            "results": [
                {
                    "name": r.name,
                    "value": None if r.value is None else value_out(r.value),
                    "descriptor": None if r.descriptor is None else descriptor_out(r.descriptor),
                    "code": _code_text(r.code),
                    "reason": r.reason,
                    "last_change": last_change_out(r.last_change),
                }
                for r in results
            ],
        }
    )


def set_reply(node: str, revision: int, incarnation: int, results: Sequence[SetResult]) -> bytes:
    return dumps(
        {
            "ok": True,
            "node": node,
            "revision": revision,
            "incarnation": incarnation_text(incarnation),
            "results": [
                {"name": r.name, "successful": r.successful, "reason": r.reason, "code": _code_text(r.code)}
                for r in results
            ],
        }
    )


def list_reply(names: Sequence[str], prefixes: Sequence[str]) -> bytes:
    return dumps({"ok": True, "names": list(names), "prefixes": list(prefixes)})


def check_reply(obj: dict[str, Any]) -> dict[str, Any]:
    """``obj`` if it is a successful reply, else the error it carries, raised."""
    if obj.get("ok") is True:
        return obj
    code = str(obj.get("code") or "INTERNAL")
    raise error_for(code, str(obj.get("message") or code))


def get_results(obj: dict[str, Any]) -> tuple[int, int, tuple[GetResult, ...]]:
    results = tuple(
        GetResult(
            name=str(r["name"]),
            value=None if r.get("value") is None else value_in(r["value"]),
            descriptor=None
            if r.get("descriptor") is None
            else descriptor_in(str(r["name"]), r["descriptor"]),
            code=code_of(str(r.get("code") or "")),
            reason=str(r.get("reason") or ""),
            last_change=last_change_in(r.get("last_change")),
        )
        for r in obj["results"]
    )
    return int(obj["revision"]), int(str(obj["incarnation"]), 16), results


def set_results(obj: dict[str, Any]) -> tuple[int, int, tuple[SetResult, ...]]:
    results = tuple(
        SetResult(
            str(r["name"]),
            bool(r["successful"]),
            str(r.get("reason") or ""),
            code_of(str(r.get("code") or "")),
        )
        for r in obj["results"]
    )
    return int(obj["revision"]), int(str(obj["incarnation"]), 16), results
