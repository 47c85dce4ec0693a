"""Content-filtered readers: Cyclone drops foreign samples before Python sees them.

A reader gets a Topic entity of its own with a native filter (the optional C
extension :mod:`paramdds.dds._nodefilter`) installed before the reader is created.
The filter reads the serialized key from the CDR bytes (XCDR1 or XCDR2) and
compares it with a table in C memory that :meth:`NativeFilter.set_nodes` replaces
whole, under a lock no Cyclone call is ever made under, so it can change while
Cyclone filters. Three kinds:

* ``nodes``: requests whose ``node_id`` is hosted here (servers), in both the
  canonical and the ``/``-prefixed form;
* ``client``: replies whose ``client_id`` is this client's;
* ``presence``: state samples that are a node's presence instance (name ``""``).

Filters only ever *drop* what the handler would drop anyway: what the C code does
not understand it accepts, and every handler keeps its own check. Where the
extension is missing (no C compiler at install time) :func:`filtered_topic`
returns a plain Topic, and :data:`STATUS` says so (logged once, see :func:`status`).

Filtering saves the receiving process's CPU, not the network: a writer still
sends every request to every matched reader.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from typing import Any

from cyclonedds.domain import DomainParticipant
from cyclonedds.topic import Topic

from ._binding import install_native_filter
from .topics import created, make_topic

try:
    from . import _nodefilter  # type: ignore[attr-defined]
except ImportError as exc:  # pragma: no cover - depends on how paramdds was installed
    _nodefilter = None
    _MISSING = f"the native filter extension is not built ({exc})"
else:
    _MISSING = ""

__all__ = [
    "NATIVE",
    "FilteredTopic",
    "NativeFilter",
    "disable_native",
    "filter_tag",
    "filtered_topic",
    "gone_of",
    "gone_tag",
    "origin_of",
    "origin_tag",
    "process_label",
    "request_filter_of",
    "status",
    "status_of",
    "status_tag",
]

log = logging.getLogger(__name__)

NATIVE = _nodefilter is not None
_warned = False

_MODES = {"nodes": 0, "client": 1, "presence": 2}


def status() -> dict[str, object]:
    """How this process filters: ``{"filter": "native"}`` or ``"handler"`` with the reason."""
    if NATIVE:
        return {"filter": "native"}
    return {"filter": "handler", "reason": _MISSING}


_TAG = "request_filter="
# a presence tag said once by a server whose twin (another process hosting the same node id)
# stopped: "gone=pid N on HOST", so monitors drop that process from the node's hosts
GONE_TAG = "gone="
ORIGIN_TAG = "origin="  # a presence tag: where the node comes from ("origin=ros2": a mirrored ROS 2 node)
# a presence tag: the node is known but its parameters are not ("status=unreachable": a ROS 2
# node the bridge sees whose parameter services do not answer)
STATUS_TAG = "status="


def filter_tag(native: bool) -> str:
    """How a server's presence says it filters requests: one item of its presence value."""
    return _TAG + ("native" if native else "handler")


def request_filter_of(tags: Iterable[object]) -> str | None:
    """``"native"`` or ``"handler"`` from a presence value's tags; None if the node does not say
    (a foreign or older server: its presence carries no value)."""
    return _tag_value(tags, _TAG)


def origin_tag(origin: str) -> str:
    """The presence tag of a node hosted for another system (``origin=ros2``: a mirrored ROS 2 node)."""
    return ORIGIN_TAG + origin


def origin_of(tags: Iterable[object]) -> str | None:
    """The presence tag ``origin`` (``"ros2"`` for a node mirrored from ROS 2 by the bridge);
    None when the node does not say (a node served here, or an older server)."""
    return _tag_value(tags, ORIGIN_TAG)


STALE = "stale"  # the status of a node whose set has waited on another process for over the lease


def status_tag(status: str) -> str:
    """The presence tag of a node that is there but not all well: ``status=unreachable`` (it
    cannot be read), ``status=stale`` (its values are the last known: a set waits on it)."""
    return STATUS_TAG + status


def status_of(tags: Iterable[object]) -> str | None:
    """The presence tag ``status`` (``"unreachable"``, ``"stale"``); None for a node that is what it says."""
    return _tag_value(tags, STATUS_TAG)


def _tag_value(tags: Iterable[object], prefix: str) -> str | None:
    """What follows ``prefix`` in the first tag that starts with it; None if none does."""
    for tag in tags:
        if isinstance(tag, str) and tag.startswith(prefix):
            return tag[len(prefix) :]
    return None


def process_label(host: str, pid: int) -> str:
    """A process hosting a node, as a ``gone=`` tag and a monitor's duplicates name it."""
    return f"pid {pid} on {host}"


def gone_tag(host: str, pid: int) -> str:
    """The presence tag that says this process stopped hosting the node (see :func:`gone_of`)."""
    return GONE_TAG + process_label(host, pid)


def gone_of(tags: Iterable[object]) -> list[str]:
    """The processes a presence says stopped hosting the node (:func:`process_label`)."""
    return [t[len(GONE_TAG) :] for t in tags if isinstance(t, str) and t.startswith(GONE_TAG)]


def disable_native() -> None:
    """Filter in the handlers only, from now on, as without the extension (for benchmarks)."""
    global _nodefilter, _MISSING, NATIVE
    _nodefilter, NATIVE = None, False
    _MISSING = "the native filter is disabled"


def _warn_once() -> None:
    global _warned
    if not _warned:
        _warned = True
        log.warning(
            "%s: every request and reply is decoded and checked in Python "
            "(reinstall paramdds with a C compiler present to filter in DDS)",
            _MISSING,
        )


class NativeFilter:
    """One filter table; install it on any number of topics with :func:`filtered_topic`."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._c: Any = _nodefilter.Filter(_MODES[kind]) if _nodefilter is not None else None
        self._nodes: frozenset[str] = frozenset()
        if kind == "nodes":
            self.set_nodes(())

    @property
    def native(self) -> bool:
        return self._c is not None

    def set_nodes(self, nodes: Iterable[str] | None) -> None:
        """Accept exactly these (canonical) node ids; ``None`` accepts every node."""
        if nodes is None:
            self._nodes = frozenset()
            if self._c is not None:
                self._c.set_ids(None)
            return
        self._nodes = frozenset(nodes)
        if self._c is not None:
            ids = [form.encode() for node in self._nodes for form in (node, "/" + node)]
            self._c.set_ids(ids)

    def set_client_id(self, client_id: int) -> None:
        if self._c is not None:
            self._c.set_client_id(client_id)

    def check(self, data: bytes) -> bool:
        """What the filter decides for one serialized sample (header included)."""
        return True if self._c is None else bool(self._c.check(data))

    def counts(self) -> tuple[int, int, int]:
        """Samples (accepted, rejected, not understood and so accepted) so far."""
        if self._c is None:
            return (0, 0, 0)
        accepted, rejected, unparsed = self._c.counts()
        return int(accepted), int(rejected), int(unparsed)


class FilteredTopic(Topic[Any]):
    """A Topic entity that holds the native filter installed on it, for as long as it lives.

    Cyclone calls the filter, which reads the filter table's C memory, for every sample
    delivered to a reader of this topic, so the table must outlive every reader of it.
    A reader's Python object holds its topic and this topic holds the filter: the filter
    is released only once every reader of the topic has been collected, and a reader
    deletes its DDS entity when collected (its finalizer). A cyclic collection runs every
    finalizer before it clears any reference, so the order holds there too. (A weak map
    keyed by the topic would not: the collector clears weak references, and would free
    the table, before it runs the finalizers that delete the readers.)
    """

    def __init__(self, participant: DomainParticipant, name: str, data_type: type, flt: NativeFilter) -> None:
        super().__init__(participant, name, data_type)
        self.native_filter = flt


def filtered_topic(participant: DomainParticipant, name: str, data_type: type, flt: NativeFilter) -> Any:
    """A Topic entity of its own for one reader, with ``flt`` installed when native.

    Create the reader on it right away; the topic keeps ``flt`` alive (:class:`FilteredTopic`).
    """
    if flt._c is None:
        _warn_once()
        return make_topic(participant, name, data_type)
    topic = created(lambda: FilteredTopic(participant, name, data_type, flt), name)
    install_native_filter(topic, flt._c.function(), flt._c.argument())
    return topic
