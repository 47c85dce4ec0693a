"""The recording's format: an MCAP file's channels, their JSON schemas, and its messages written and read.

``paramdds record`` writes, and ``history --from`` / ``diff --from`` read, an MCAP file
whose channels all carry JSON messages (message encoding ``json``) described by JSON
Schemas (schema encoding ``jsonschema``, what Foxglove and Lichtblick read):

* :data:`SNAPSHOT` ``/paramdds/snapshot``: one node's whole state, one message per node at
  the start of each file: ``{node, online, incarnation, revision, time, parameters: [{name,
  type, value, descriptor, last_change}]}`` (``value`` tagged ``{type, value}``, ``descriptor``
  in its tagged JSON form, ``last_change`` ``{who, verified, via, time, revision}`` or null;
  ``incarnation``, a 64-bit number, as a decimal string: JavaScript's numbers hold 53 bits);
* :data:`CHANGES` ``/paramdds/changes``: one parameter's change: ``{node, name, kind, type,
  value, old, new, who, verified, via, revision, time, source}``; ``value`` is the new value as
  a number when it is one (a bool is 0 or 1), else null: what a Plot panel graphs; ``old``
  and ``new`` are tagged values (null: the parameter did not exist / was deleted);
  ``source`` is ``live`` (seen by the monitor) or ``history`` (read from the node's history
  to fill revisions the monitor skipped);
* :data:`PRESENCE` ``/paramdds/presence``: ``{node, event, online, incarnation, revision, time}``
  (``event`` online, offline or restarted);
* :data:`GAPS` ``/paramdds/gaps``: ``{node, after, before, reason, time}``: the node's revisions
  after ``after`` and before ``before`` are not in the recording (the monitor skipped them
  and the node's history did not hold them).

Each message's log time is its event's time (a change's: when the node committed it;
a snapshot's: when it was taken), in nanoseconds since the epoch. Times inside messages
are ISO 8601 UTC. Pure: builders return dicts, :func:`encode` makes the bytes, and
:func:`read_recording` reads a file (finished, or torn by a killed recorder: read up to
the tear) with the ``mcap`` package.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..core.descriptors import ParameterDescriptor
from ..core.history import HistoryQuery, HistoryRecord
from ..core.jsonform import descriptor_of_json, json_descriptor, json_tagged_value, value_of_tagged
from ..core.results import LastChange, iso_time
from ..core.values import ParameterType, ParameterValue
from ..errors import FileFormatError, ParamddsError

if TYPE_CHECKING:
    from mcap.records import Message

__all__ = [
    "CHANGES",
    "CHANNELS",
    "GAPS",
    "MESSAGE_ENCODING",
    "PRESENCE",
    "SCHEMA_ENCODING",
    "SNAPSHOT",
    "Channel",
    "NodeSnapshot",
    "Recording",
    "change_message",
    "decode",
    "encode",
    "gap_message",
    "plot_value",
    "presence_message",
    "read_recording",
    "snapshot_message",
]

MESSAGE_ENCODING = "json"
SCHEMA_ENCODING = "jsonschema"
PROFILE = ""  # no MCAP profile: plain JSON channels
LIBRARY = "paramdds record"

_TAGGED = {
    "type": ["object", "null"],
    "properties": {"type": {"type": "string"}, "value": {}},
    "required": ["type", "value"],
}
_LAST_CHANGE = {
    "type": ["object", "null"],
    "properties": {
        "who": {"type": "string"},
        "verified": {"type": "boolean"},
        "via": {"type": "string"},
        "time": {"type": "string", "format": "date-time"},
        "revision": {"type": "integer"},
    },
}


@dataclass(frozen=True)
class Channel:
    """One channel of the recording: its topic and the JSON Schema of its messages."""

    topic: str
    schema_name: str
    schema: Mapping[str, Any]

    def schema_bytes(self) -> bytes:
        return json.dumps(self.schema, separators=(",", ":")).encode()


SNAPSHOT = Channel(
    "/paramdds/snapshot",
    "paramdds.NodeSnapshot",
    {
        "title": "paramdds.NodeSnapshot",
        "description": "One node's whole state when the recording (or this file of it) started",
        "type": "object",
        "properties": {
            "node": {"type": "string"},
            "online": {"type": "boolean"},
            "incarnation": {"type": "string", "description": "the server's start (a u64, as text)"},
            "revision": {"type": "integer"},
            "time": {"type": "string", "format": "date-time"},
            "parameters": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "name": {"type": "string"},
                        "type": {"type": "string"},
                        "value": _TAGGED,
                        "descriptor": {"type": "object"},
                        "last_change": _LAST_CHANGE,
                    },
                    "required": ["name", "type", "value"],
                },
            },
        },
        "required": ["node", "online", "revision", "parameters"],
    },
)

CHANGES = Channel(
    "/paramdds/changes",
    "paramdds.ParameterChange",
    {
        "title": "paramdds.ParameterChange",
        "description": "One parameter's change: old and new value, who made it, through what, when",
        "type": "object",
        "properties": {
            "node": {"type": "string"},
            "name": {"type": "string"},
            "kind": {"type": "string", "enum": ["added", "modified", "deleted"]},
            "type": {"type": "string"},
            "value": {"type": ["number", "null"], "description": "the new value as a number (bool: 0/1)"},
            "old": _TAGGED,
            "new": _TAGGED,
            "who": {"type": "string"},
            "verified": {"type": "boolean"},
            "via": {"type": "string"},
            "revision": {"type": "integer"},
            "time": {"type": "string", "format": "date-time"},
            "source": {"type": "string", "enum": ["live", "history"]},
        },
        "required": ["node", "name", "kind", "type", "value", "old", "new", "revision"],
    },
)

PRESENCE = Channel(
    "/paramdds/presence",
    "paramdds.Presence",
    {
        "title": "paramdds.Presence",
        "description": "A node going online or offline, or restarting (a new incarnation)",
        "type": "object",
        "properties": {
            "node": {"type": "string"},
            "event": {"type": "string", "enum": ["online", "offline", "restarted"]},
            "online": {"type": "boolean"},
            "incarnation": {"type": "string", "description": "the server's start (a u64, as text)"},
            "revision": {"type": "integer"},
            "time": {"type": "string", "format": "date-time"},
        },
        "required": ["node", "event", "online"],
    },
)

GAPS = Channel(
    "/paramdds/gaps",
    "paramdds.Gap",
    {
        "title": "paramdds.Gap",
        "description": "A node's revisions after 'after' and before 'before' are not in the recording",
        "type": "object",
        "properties": {
            "node": {"type": "string"},
            "after": {"type": "integer"},
            "before": {"type": "integer"},
            "reason": {"type": "string"},
            "time": {"type": "string", "format": "date-time"},
        },
        "required": ["node", "after", "before", "reason"],
    },
)

CHANNELS = (SNAPSHOT, CHANGES, PRESENCE, GAPS)


# -- building messages -----------------------------------------------------------------


def plot_value(value: ParameterValue | None) -> float | int | None:
    """The value as a Plot panel graphs it: a number as itself, a bool as 0 or 1, a double
    that is not finite and everything else as null."""
    if value is None:
        return None
    v = value.value
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, int):
        return v
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    return None


def _tagged(value: ParameterValue | None) -> dict[str, object] | None:
    if value is None or value.type is ParameterType.NOT_SET:
        return None
    return json_tagged_value(value)


def _blame(last: LastChange | None) -> dict[str, object] | None:
    return None if last is None else last.to_json()


def snapshot_message(
    node: str,
    *,
    online: bool,
    incarnation: int,
    revision: int,
    time_ns: int,
    parameters: Iterable[tuple[str, ParameterValue, ParameterDescriptor, LastChange | None]],
) -> dict[str, object]:
    """A :data:`SNAPSHOT` message: ``parameters`` are ``(name, value, descriptor, last change)``."""
    return {
        "node": node,
        "online": online,
        "incarnation": str(incarnation),
        "revision": revision,
        "time": iso_time(time_ns),
        "parameters": [
            {
                "name": name,
                "type": value.type.label,
                "value": _tagged(value),
                "descriptor": json_descriptor(descriptor, tagged=True),
                "last_change": _blame(last),
            }
            for name, value, descriptor, last in parameters
            if value.type is not ParameterType.NOT_SET
        ],
    }


def change_message(
    node: str,
    name: str,
    old: ParameterValue | None,
    new: ParameterValue | None,
    *,
    who: str,
    verified: bool,
    via: str,
    revision: int,
    time_ns: int,
    source: str = "live",
) -> dict[str, object]:
    """A :data:`CHANGES` message (``old`` None: added; ``new`` None: deleted)."""
    if new is not None and new.type is ParameterType.NOT_SET:
        new = None
    kind = "deleted" if new is None else ("added" if old is None else "modified")
    shown = new if new is not None else old
    return {
        "node": node,
        "name": name,
        "kind": kind,
        "type": shown.type.label if shown is not None else "not_set",
        "value": plot_value(new),
        "old": _tagged(old),
        "new": _tagged(new),
        "who": who,
        "verified": verified,
        "via": via,
        "revision": revision,
        "time": iso_time(time_ns),
        "source": source,
    }


def presence_message(
    node: str, event: str, *, online: bool, incarnation: int, revision: int, time_ns: int
) -> dict[str, object]:
    """A :data:`PRESENCE` message (``event`` online, offline or restarted)."""
    return {
        "node": node,
        "event": event,
        "online": online,
        "incarnation": str(incarnation),
        "revision": revision,
        "time": iso_time(time_ns),
    }


def gap_message(node: str, after: int, before: int, reason: str, time_ns: int) -> dict[str, object]:
    """A :data:`GAPS` message: revisions strictly between ``after`` and ``before`` are missing."""
    return {"node": node, "after": after, "before": before, "reason": reason, "time": iso_time(time_ns)}


def encode(message: Mapping[str, object]) -> bytes:
    """A message's bytes: compact JSON, UTF-8."""
    return json.dumps(message, separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode()


def decode(data: bytes) -> dict[str, Any]:
    """A message from its bytes (FileFormatError when they are not a JSON object)."""
    try:
        obj = json.loads(data)
    except (ValueError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"not a JSON message: {exc}") from None
    if not isinstance(obj, dict):
        raise FileFormatError("not a JSON object message")
    return obj


# -- reading a recording ---------------------------------------------------------------


@dataclass
class NodeSnapshot:
    """One node's state as a :data:`SNAPSHOT` message says it."""

    node: str
    time_ns: int
    revision: int
    online: bool
    values: dict[str, ParameterValue]
    descriptors: dict[str, ParameterDescriptor]


@dataclass
class Recording:
    """What a recording holds, in file order: snapshots, changes (as history records,
    ``seq`` their order), presence and gap messages; ``torn`` says where a torn file ended."""

    snapshots: list[NodeSnapshot] = field(default_factory=list)
    changes: list[HistoryRecord] = field(default_factory=list)
    presence: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    gaps: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    torn: str | None = None

    @property
    def nodes(self) -> list[str]:
        """Every node the recording names, sorted."""
        names = {s.node for s in self.snapshots} | {r.node for r in self.changes}
        return sorted(names)

    def history(self, node: str, query: HistoryQuery) -> list[HistoryRecord]:
        """``node``'s recorded changes that ``query`` matches, in file order (a recording
        holds applied changes only: a query for refused writes matches none)."""
        return [r for r in self.changes if r.node == node and query.matches(r)]

    def state_at(
        self, node: str, *, revision: int | None = None, time_ns: int | None = None
    ) -> tuple[dict[str, ParameterValue], dict[str, ParameterDescriptor]] | None:
        """``node``'s values (and descriptors) as they were: its first snapshot, then every change
        up to ``revision`` or ``time_ns`` (neither: to the end). None when the recording holds
        neither a snapshot of the node nor a change of it up to that point."""
        base = next((s for s in self.snapshots if s.node == node), None)
        values = dict(base.values) if base else {}
        descriptors = dict(base.descriptors) if base else {}
        seen = base is not None
        if base is not None and (
            (time_ns is not None and base.time_ns > time_ns)
            or (revision is not None and base.revision > revision)
        ):
            return None  # the recording starts after the point asked for
        for r in self.changes:
            if r.node != node:
                continue
            if revision is not None and r.revision > revision:
                break
            if time_ns is not None and r.time_ns > time_ns:
                break
            seen = True
            if r.new is None:
                values.pop(r.name, None)
            else:
                values[r.name] = r.new
        return (values, descriptors) if seen else None


def _value(obj: object) -> ParameterValue | None:
    return None if obj is None else value_of_tagged(obj)


def _change(seq: int, log_time: int, m: Mapping[str, Any]) -> HistoryRecord:
    return HistoryRecord(
        seq,
        str(m["node"]),
        str(m["name"]),
        int(m["revision"]),
        log_time,
        str(m.get("who", "")),
        bool(m.get("verified", False)),
        str(m.get("via", "")),
        _value(m.get("old")),
        _value(m.get("new")),
    )


def _snapshot(log_time: int, m: Mapping[str, Any]) -> NodeSnapshot:
    values: dict[str, ParameterValue] = {}
    descriptors: dict[str, ParameterDescriptor] = {}
    for p in m.get("parameters", []):
        name = str(p["name"])
        value = _value(p.get("value"))
        if value is not None:
            values[name] = value
        if p.get("descriptor") is not None:
            descriptors[name] = descriptor_of_json(name, p["descriptor"])
    return NodeSnapshot(
        str(m["node"]), log_time, int(m.get("revision", 0)), bool(m.get("online", False)), values, descriptors
    )


def read_recording(path: str) -> Recording:
    """Every message of the recording at ``path``, in file order. A file cut short (its
    recorder killed) is read up to the tear and :attr:`Recording.torn` says so; a file that
    is not a recording raises FileFormatError."""
    from mcap.exceptions import InvalidMagic
    from mcap.records import Channel as McapChannel
    from mcap.records import DataEnd, Message
    from mcap.stream_reader import StreamReader

    try:
        stream = open(path, "rb")  # noqa: SIM115 (closed below, after the records are read)
    except OSError as exc:
        raise FileFormatError(f"cannot read: {exc.strerror or exc}", file=path) from None
    out = Recording()
    topics: dict[int, str] = {}
    count = 0
    whole = False  # the data section's end was read
    with stream:
        try:
            for record in StreamReader(stream, skip_magic=False).records:
                if isinstance(record, McapChannel):
                    topics[record.id] = record.topic
                elif isinstance(record, Message):
                    count += 1
                    _take(out, topics.get(record.channel_id, ""), record)
                elif isinstance(record, DataEnd):
                    whole = True
                    break  # the summary that follows repeats what was read
        except ParamddsError as exc:
            raise FileFormatError(f"not a paramdds recording: {exc}", file=path) from None
        except InvalidMagic:
            raise FileFormatError("not an MCAP file", file=path) from None
        except Exception:  # the mcap reader's errors at a torn tail (EOF, CRC, a bad length)
            pass
        if not whole:
            out.torn = (
                f"{path} is not finished (still being recorded, or its recorder was killed): "
                f"read up to its last whole chunk, {count} messages"
            )
    return out


def _take(out: Recording, topic: str, record: Message) -> None:
    log_time = int(record.log_time)
    if topic == CHANGES.topic:
        out.changes.append(_change(len(out.changes) + 1, log_time, decode(record.data)))
    elif topic == SNAPSHOT.topic:
        out.snapshots.append(_snapshot(log_time, decode(record.data)))
    elif topic == PRESENCE.topic:
        out.presence.append((log_time, decode(record.data)))
    elif topic == GAPS.topic:
        out.gaps.append((log_time, decode(record.data)))
