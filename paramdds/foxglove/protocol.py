"""The Foxglove WebSocket protocol's messages this server reads and writes, and the descriptors channel.

Pure functions: a client's JSON text → an :data:`Op` (:func:`parse`, :class:`ProtocolError`
with a one-line reason for anything else), and the server's messages as JSON-ready dicts
(``server_info``, ``status``, ``advertise``, ``parameter_values``), plus the binary
``messageData`` frame (opcode 1, subscription id u32 LE, timestamp ns u64 LE, payload).

The server speaks the subprotocols :data:`SUBPROTOCOLS` (the same messages under either
name: ``foxglove.websocket.v1`` is what ``@foxglove/ws-protocol`` and Lichtblick ask for,
``foxglove.sdk.v1`` what the Foxglove SDK's clients do).

The channel :data:`TOPIC` carries, as JSON, one node's parameters with their descriptors
and last changes (:func:`node_message`, schema :data:`NODE_SCHEMA`): what the protocol's
parameter messages cannot say.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..core.descriptors import ParameterDescriptor
from ..core.jsonform import json_descriptor, json_value
from ..core.results import LastChange
from ..core.values import ParameterValue
from .names import foxglove_name

SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")
CAPABILITIES = ("parameters", "parametersSubscribe")

INFO, WARNING, ERROR = 0, 1, 2  # status levels

MESSAGE_DATA = 0x01  # binary opcode, server → client
_MESSAGE_HEADER = struct.Struct("<BIQ")

CHANNEL_ID = 1
TOPIC = "/paramdds/parameters"
SCHEMA_NAME = "paramdds.NodeParameters"
MAX_NAMES = 1_000_000  # names in one request


class ProtocolError(Exception):
    """A client message this server cannot act on; its text is the ``status`` sent back."""


@dataclass(frozen=True)
class GetParameters:
    names: tuple[str, ...]  # empty: every parameter
    id: str | None


@dataclass(frozen=True)
class SetParameters:
    parameters: tuple[Mapping[str, object], ...]  # each {"name", "value"?, "type"?}
    id: str | None


@dataclass(frozen=True)
class SubscribeParameters:
    names: tuple[str, ...]  # empty: every parameter


@dataclass(frozen=True)
class UnsubscribeParameters:
    names: tuple[str, ...]  # empty: every parameter


@dataclass(frozen=True)
class Subscribe:
    subscriptions: tuple[tuple[int, int], ...]  # (subscription id, channel id)


@dataclass(frozen=True)
class Unsubscribe:
    ids: tuple[int, ...]


Op = GetParameters | SetParameters | SubscribeParameters | UnsubscribeParameters | Subscribe | Unsubscribe

# operations of the protocol this server does not offer (it advertises no capability for them)
_UNOFFERED = frozenset(
    {
        "advertise",
        "unadvertise",
        "callService",
        "fetchAsset",
        "subscribeConnectionGraph",
        "unsubscribeConnectionGraph",
        "playbackControl",
    }
)


def parse(text: str) -> Op:
    """A client's text message as an :data:`Op`; ProtocolError naming what is wrong."""
    try:
        msg = json.loads(text)
    except ValueError as exc:
        raise ProtocolError(f"not JSON: {exc}") from None
    if not isinstance(msg, dict):
        raise ProtocolError("a message is a JSON object with an 'op'")
    op = msg.get("op")
    if op == "getParameters":
        return GetParameters(_names(msg), _id(msg))
    if op == "setParameters":
        params = msg.get("parameters")
        if not isinstance(params, list) or not all(
            isinstance(p, dict) and isinstance(p.get("name"), str) for p in params
        ):
            raise ProtocolError("setParameters: 'parameters' is a list of {name, value, type}")
        return SetParameters(tuple(params), _id(msg))
    if op == "subscribeParameterUpdates":
        return SubscribeParameters(_names(msg))
    if op == "unsubscribeParameterUpdates":
        return UnsubscribeParameters(_names(msg))
    if op == "subscribe":
        subs = msg.get("subscriptions")
        if not isinstance(subs, list) or not all(
            isinstance(s, dict) and _is_int(s.get("id")) and _is_int(s.get("channelId")) for s in subs
        ):
            raise ProtocolError("subscribe: 'subscriptions' is a list of {id, channelId}")
        return Subscribe(tuple((int(s["id"]), int(s["channelId"])) for s in subs))
    if op == "unsubscribe":
        ids = msg.get("subscriptionIds")
        if not isinstance(ids, list) or not all(_is_int(i) for i in ids):
            raise ProtocolError("unsubscribe: 'subscriptionIds' is a list of integers")
        return Unsubscribe(tuple(int(i) for i in ids))
    if op in _UNOFFERED:
        offered = ", ".join(CAPABILITIES)
        raise ProtocolError(f"{op} is not offered by this server (its capabilities: {offered})")
    raise ProtocolError(f"unknown op {str(op)[:40]!r}")


def _is_int(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 2**32


def _names(msg: Mapping[str, Any]) -> tuple[str, ...]:
    names = msg.get("parameterNames", [])
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names) or len(names) > MAX_NAMES:
        raise ProtocolError(f"{msg.get('op')}: 'parameterNames' is a list of strings")
    return tuple(names)


def _id(msg: Mapping[str, Any]) -> str | None:
    rid = msg.get("id")
    if rid is None:
        return None
    if not isinstance(rid, str):
        raise ProtocolError(f"{msg.get('op')}: 'id' is a string")
    return rid


# -- the server's messages ----------------------------------------------------------------------


def server_info(name: str, session_id: str, metadata: Mapping[str, str]) -> dict[str, object]:
    return {
        "op": "serverInfo",
        "name": name,
        "capabilities": list(CAPABILITIES),
        "supportedEncodings": [],
        "metadata": dict(metadata),
        "sessionId": session_id,
    }


def status(level: int, message: str, rid: str | None = None) -> dict[str, object]:
    """A ``status`` (``rid``: the request it answers, as the status id, for ``removeStatus``)."""
    out: dict[str, object] = {"op": "status", "level": level, "message": message}
    if rid is not None:
        out["id"] = rid
    return out


def parameter_values(parameters: Sequence[Mapping[str, object]], rid: str | None = None) -> dict[str, object]:
    out: dict[str, object] = {"op": "parameterValues", "parameters": list(parameters)}
    if rid is not None:
        out["id"] = rid
    return out


def advertise() -> dict[str, object]:
    """The descriptors channel, advertised to every client on connect."""
    return {
        "op": "advertise",
        "channels": [
            {
                "id": CHANNEL_ID,
                "topic": TOPIC,
                "encoding": "json",
                "schemaName": SCHEMA_NAME,
                "schema": json.dumps(NODE_SCHEMA, separators=(",", ":")),
                "schemaEncoding": "jsonschema",
            }
        ],
    }


def message_data(subscription: int, time_ns: int, payload: bytes) -> bytes:
    """A binary ``messageData`` frame."""
    return _MESSAGE_HEADER.pack(MESSAGE_DATA, subscription, time_ns) + payload


def dumps(msg: Mapping[str, object]) -> str:
    return json.dumps(msg, allow_nan=False, separators=(",", ":"))


# -- the descriptors channel ------------------------------------------------------------------

_RANGE = {"type": ["object", "null"]}
NODE_SCHEMA: dict[str, object] = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": SCHEMA_NAME,
    "description": "One node's parameters as paramdds holds them: value, descriptor, last change",
    "type": "object",
    "required": ["node", "online", "revision", "parameters"],
    "properties": {
        "node": {"type": "string", "description": "the node id (site/node over Zenoh)"},
        "online": {"type": "boolean"},
        "revision": {"type": "integer", "description": "the node's revision"},
        "parameters": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["name", "parameter", "type", "value", "descriptor", "last_change"],
                "properties": {
                    "name": {"type": "string", "description": "the Foxglove name, /<node>.<param>"},
                    "parameter": {"type": "string", "description": "the parameter's name on its node"},
                    "type": {"type": "string", "description": "paramdds' type: bool, integer, double, ..."},
                    "value": {
                        "description": "the value (byte arrays as lists of integers; a double that "
                        'is not finite as "nan", "inf" or "-inf")'
                    },
                    "descriptor": {
                        "type": "object",
                        "properties": {
                            "type": {"type": "string"},
                            "description": {"type": "string"},
                            "read_only": {"type": "boolean"},
                            "dynamic_typing": {"type": "boolean"},
                            "integer_range": _RANGE,
                            "floating_point_range": _RANGE,
                            "additional_constraints": {"type": "string"},
                            "validators": {"type": "array"},
                        },
                    },
                    "last_change": {
                        "type": ["object", "null"],
                        "description": "who last changed it, whether verified, through what, when, "
                        "at which revision",
                        "properties": {
                            "who": {"type": "string"},
                            "verified": {"type": "boolean"},
                            "via": {"type": "string"},
                            "time": {"type": "string", "description": "ISO 8601, UTC"},
                            "revision": {"type": "integer"},
                        },
                    },
                },
            },
        },
    },
}


def node_message(
    node: str,
    online: bool,
    revision: int,
    parameters: Mapping[str, tuple[ParameterValue, ParameterDescriptor]],
    last_changes: Mapping[str, LastChange],
) -> dict[str, object]:
    """One node's message on :data:`TOPIC` (no parameters while it is offline)."""
    rows = []
    for name in sorted(parameters) if online else ():
        value, descriptor = parameters[name]
        last = last_changes.get(name)
        rows.append(
            {
                "name": foxglove_name(node, name),
                "parameter": name,
                "type": value.type.label,
                "value": json_value(value),
                "descriptor": json_descriptor(descriptor),
                "last_change": last.to_json() if last is not None else None,
            }
        )
    return {"node": node, "online": online, "revision": revision, "parameters": rows}
