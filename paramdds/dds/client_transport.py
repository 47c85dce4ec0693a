"""The DDS transport of a client: requests and replies on the six request/reply topics, and presence.

Correlation: every request carries this transport's random 64-bit ``client_id`` and
the call's request id. Reply readers are content-filtered on that ``client_id`` (a
native filter reading it from the serialized reply, see :mod:`.filters`), and the
reply handler checks it again, so two clients (in one process or two) never take
each other's replies; replies are matched to calls by request id. Many calls may be
outstanding at once (pipelining).

Presence: the state reader is content-filtered on presence instances (name ``""``),
so the parameters' state samples never reach Python here. They still reach the
process: a new reader is sent every server's retained state, so a one-shot client
(``one_shot``) creates that reader only when a call needs presence, and each request
topic's endpoints on its first call.

A node that has no presence instance is ABSENT only once discovery has settled
(:mod:`.discovery` states the rule: a state writer was found, every matched one has
delivered, and nothing changed for a quiet period that grows with how slow discovery
was); until then it is UNKNOWN, and a call that fails says how far discovery got.
The copies of a request carry the same ids: the server answers a repeat from its
reply cache.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import InvalidStateError
from functools import partial
from typing import Any

from cyclonedds.core import DDSException, InstanceState
from cyclonedds.domain import DomainParticipant

from ..core.call import Call, Failure, GetRequest, HistoryRequest, ListRequest, Mark, Request, closed_error
from ..core.deadline import deadline_for
from ..core.history import HistoryPage
from ..core.limits import check_request_size
from ..core.names import canonical_node_id
from ..core.replies import GetReply, NodeInfo, SetReply
from ..core.request import to_parameters
from ..core.results import GetResult, ListResult, SetResult
from ..core.revision import Revision
from ..errors import (
    CallTimeoutError,
    OutcomeUnknownError,
    ParamddsError,
    UnavailableError,
    code_of,
    error_for,
)
from .client_protocol import PendingCall
from .discovery import MIN_QUIET, DiscoveryState, DiscoveryWatch, Presence
from .dispatch import Dispatcher
from .filters import NativeFilter, filtered_topic, origin_of, request_filter_of, status_of
from .participant import peer_mismatches
from .qos import QosProfiles
from .transport import Writers, transport_of
from .wire import types as wire
from .wire.cdr import is_malformed
from .wire.convert import descriptor_from_wire, parameter_to_wire, value_from_wire
from .wire.history import last_change_from_wire, page_from_wire, query_to_wire

log = logging.getLogger(__name__)

PRESENCE_GRACE = MIN_QUIET  # the least quiet discovery time before a node without presence counts as absent
_READ_ALL = 1 << 24  # "every sample" for read(); Cyclone refuses N >= 2**28
PRESENCE_POLL = 0.02  # seconds between presence checks in wait_for_node
ONLINE_FRESH = 0.1  # seconds a write trusts a node's last "online" before looking again (see _check_unsent)
REQUEST_TOPICS = ("SetParametersRequest", "GetParametersRequest", "ListParametersRequest")
_GONE = (Presence.OFFLINE, Presence.ABSENT)


class DdsClientTransport:
    """A client's calls and presence on DDS (a :class:`~.client_protocol.ClientTransport`).

    ``presence_grace`` is the least time discovery must stay quiet before a node never
    seen counts as absent (:mod:`.discovery`). ``one_shot`` is for processes that make a
    call or a few, such as the CLI's verbs: the presence reader is created only once a
    call needs it (see :meth:`watch`), and a request topic's writer and reply reader on
    its first call (a long-lived client makes them now, so they are matched before its
    first call).
    """

    resends = True
    grace = 0.0

    def __init__(
        self,
        participant: DomainParticipant,
        qos: QosProfiles | None = None,
        *,
        presence_grace: float = PRESENCE_GRACE,
        client_id: int | None = None,
        one_shot: bool = False,
    ) -> None:
        # os.urandom, not secrets: the same random bits without importing hmac, hashlib and random
        self.client_id = client_id or int.from_bytes(os.urandom(8), "little") or 1
        self.participant = participant
        self._qos = qos or QosProfiles.load()
        self._closing = threading.Event()
        self._pending: dict[int, PendingCall] = {}
        # secure mode (.transport): a writer per target node, each in that node's partition,
        # and a topic's endpoints made on its first call (a viewer may never set)
        self._transport = transport_of(participant)
        self._writers: dict[str, Any] = {}
        self._dispatcher = Dispatcher(participant, "paramdds-client")
        self.reply_filter = NativeFilter("client")
        self.reply_filter.set_client_id(self.client_id)
        self._reply_readers: dict[str, Any] = {}  # by request topic
        self._match_counts: dict[int, int] = {}  # by id() of the request writer (one per node when secure)
        self._endpoints_lock = threading.Lock()
        self._made = Writers(self._transport, opening=self._open_topic)
        for request in () if one_shot else REQUEST_TOPICS:  # plain: one writer per topic, made now
            writer = self._made.early(request, self._qos.writer(request))
            if writer is not None:
                self._writers[request] = writer
        self.presence_filter = NativeFilter("presence")
        self.presence_filter.set_nodes(None)  # every node's presence, no parameter samples
        self._grace = presence_grace
        self.presence_reader: Any = None  # the presence reader and its discovery watch: see watch()
        self.discovery_watch: DiscoveryWatch | None = None
        self._online_at: dict[str, float] = {}  # node -> when a write last found it online
        self._watch_lock = threading.Lock()
        if not one_shot:
            self.watch()
        self._dispatcher.start()

    def _open_topic(self, request: str) -> None:
        """The reply reader of one request topic (made before its first request writer)."""
        name = request.replace("Request", "Response")
        # without the native filter every client's replies arrive; _on_replies keeps ours
        topic = filtered_topic(self.participant, name, wire.TOPICS[name], self.reply_filter)
        reader = self._transport.reader(topic, self._qos.reader(name))
        self._reply_readers[request] = reader
        self._dispatcher.add(reader, self._transport.guard(reader, self._on_replies))

    def _writer_for(self, topic: str, node: str) -> Any:
        """The writer of ``topic`` for ``node``: the one writer, or in secure mode that node's."""
        found = self._writers.get(topic)
        if found is not None:
            return found
        with self._endpoints_lock:
            return self._made.get(topic, node, self._qos.writer(topic))

    def watch(self) -> DiscoveryWatch:
        """The presence reader's discovery watch, creating both on first use.

        A new ``ParameterEvents`` reader is sent every server's retained state (all of
        its parameters: the filter drops them only on arrival), so a one-shot process
        (``one_shot``) creates it only when a call needs presence: a reply late by the
        first resend, :meth:`wait_for_node`, :meth:`nodes`, :meth:`presence`.
        """
        with self._watch_lock:
            if self.discovery_watch is None:
                topic = filtered_topic(
                    self.participant, "ParameterEvents", wire.ParameterEvent, self.presence_filter
                )
                # secure: a few samples per instance, to skip one a writer had no right to write
                qos = self._transport.history(self._qos.reader("ParameterEvents"))
                self.presence_reader = self._transport.reader(topic, qos)
                self.discovery_watch = DiscoveryWatch(
                    self.participant,
                    self.presence_reader,
                    [*self._writers.values(), *self._reply_readers.values()],
                    min_quiet=self._grace,
                )
            return self.discovery_watch

    def close(self) -> None:
        self._closing.set()
        self._dispatcher.close()
        with self._watch_lock:
            if self.discovery_watch is not None:
                self.discovery_watch.close()
        for pending in list(self._pending.values()):
            if not pending.future.done():
                pending.future.set_exception(closed_error(pending.call))
        self._pending.clear()

    # -- a call -----------------------------------------------------------------------

    def canonical(self, node: str) -> str:
        return canonical_node_id(node)

    def start(self, request: Request, call: Call) -> PendingCall:
        node, me, rid = call.node, self.client_id, call.request_id
        sample: Any
        if isinstance(request, ListRequest):
            if request.depth < 0:
                raise ParamddsError(f"depth must be 0 (recursive) or positive, got {request.depth}")
            topic = "ListParametersRequest"
            sample = wire.ListParametersRequest(
                node_id=node,
                client_id=me,
                request_id=rid,
                depth=request.depth,
                prefixes=list(request.prefixes),
            )
        elif isinstance(request, GetRequest):
            check_request_size(len(request.names), "get")
            topic = "GetParametersRequest"
            sample = wire.GetParametersRequest(
                node_id=node,
                client_id=me,
                request_id=rid,
                with_descriptors=request.with_descriptors,
                names=list(request.names),
            )
        elif isinstance(request, HistoryRequest):
            topic = "GetParametersRequest"
            sample = wire.GetParametersRequest(
                node_id=node,
                client_id=me,
                request_id=rid,
                names=list(request.query.names),
                history=[query_to_wire(request.query)],
            )
        else:
            expected = _expected(request.if_revision)
            parameters = [parameter_to_wire(p) for p in to_parameters(request.params)]
            if self._check_unsent(node):
                call.saw(Presence.ONLINE)
            topic = "SetParametersRequest"
            sample = wire.SetParametersRequest(
                node_id=node,
                client_id=me,
                request_id=rid,
                atomic=request.atomic,
                expected_revision=expected.revision,
                parameters=parameters,
                expected_incarnation=expected.incarnation,
                deadline=deadline_for(call.timeout),
                who=request.who,
                via=request.via,
            )
        writer = self._writer_for(topic, node)
        pending = PendingCall(call, topic, sample, writer, self._match_counts.get(id(writer), 0))
        self._pending[rid] = pending
        return pending

    def route_known(self, pending: PendingCall) -> bool:
        return True

    def route(self, pending: PendingCall) -> None:
        """Nothing to wait for: a write to a node known gone was refused by :meth:`start`."""

    def send(self, pending: PendingCall) -> None:
        """Send (or send again) the request, noting whether a copy can have reached a node: a
        VOLATILE writer with no matched reader delivers to no one, then or later (a reader that
        matches later gets a copy, see :meth:`newly_matched`), so a write that never met a
        reader was never sent and cannot be applied (secure mode without a valid identity:
        nobody matches)."""
        writer: Any = pending.via  # the binding's status getters are untyped
        call = pending.call
        try:
            if not call.write:
                writer.write(pending.message)
                return
            before = writer.get_publication_matched_status().current_count
            writer.write(pending.message)
            reached = bool(before or writer.get_publication_matched_status().current_count)
            call.sent(reached, time.monotonic())
            if reached and call.copies == 1 and pending.message.expected_incarnation:
                pending.serving_life = self._serving_life(call.node, since_first_copy=False) or 0
        except Exception as exc:
            raise ParamddsError(f"could not send the request to {call.node!r}: {exc}") from exc

    def newly_matched(self, pending: PendingCall) -> bool:
        """Whether the topic of ``pending`` has matched a new peer since the count was last taken."""
        writer: Any = pending.via  # the binding's status getters are untyped
        count = (
            writer.get_publication_matched_status().total_count
            + self._reply_readers[pending.kind].get_subscription_matched_status().total_count
        )
        self._match_counts[id(writer)] = count
        if count == pending.matched:
            return False
        pending.matched = count
        return True

    def discovery_mark(self) -> Mark | None:
        if self.discovery_watch is None:
            return None
        state = self.discovery_watch.state()  # keeps the time of the last discovery change precise
        # a server excused as dead before it delivered may host any node: no absence is sure
        return Mark(state.settled, state.liveliness, sure=state.dead_writers == 0)

    def finish(self, pending: PendingCall) -> None:
        self._pending.pop(pending.call.request_id, None)

    def error(self, pending: PendingCall, failure: Failure, waited: float) -> ParamddsError:
        node = pending.node
        if failure is Failure.OUTCOME_UNKNOWN:
            return self._outcome_unknown(node, waited)
        if failure is Failure.TIMEOUT:
            return CallTimeoutError(f"no answer from node {node!r} within {waited:g} s{self._mismatched()}")
        if failure is Failure.CLOSED:
            return closed_error(pending.call)
        # a write a peer took, held and sure never to land (paramdds.core.call): say so
        held = "; no server hosting it took the request, which is sent no more"
        return self._not_seen(node, waited, held if pending.call.may_apply else "")

    def _check_unsent(self, node: str) -> bool:
        """A write to a node this client already knows to be offline or absent is not sent:
        UNAVAILABLE is then true (the request never left this process). A client that does not
        watch presence yet (``one_shot``) sends at once, and learns later. True: it is (or was
        just) online, so a copy may reach it.

        The verdict "online" is trusted for :data:`ONLINE_FRESH` seconds (presence itself lags
        by up to the 1 s lease): a write that is sent is never reported failed, so a stale
        "online" costs only a slower, still true, answer; the lookup costs ~25 µs a set."""
        seen = self._online_at.get(node)
        if self.discovery_watch is None:
            return False
        if seen is not None and time.monotonic() - seen < ONLINE_FRESH:
            return True
        state = self.presence(node)
        if state is Presence.ONLINE:
            self._online_at[node] = time.monotonic()
        elif state is Presence.OFFLINE:
            raise UnavailableError(f"node {node!r} is offline: the request was not sent")
        if state is Presence.ABSENT:
            why = self.watch().state().describe()
            raise UnavailableError(f"node {node!r} is not present ({why}): the request was not sent")
        return state is Presence.ONLINE

    def _on_replies(self, samples: Sequence[Any]) -> None:
        me = self.client_id
        for reply in samples:
            if not reply.sample_info.valid_data or reply.client_id != me:
                continue
            pending = self._pending.pop(reply.request_id, None)
            if pending is not None and not pending.future.done():
                later = _refused_by_a_later_life(pending, reply, partial(self._serving_life, pending.node))
                if later is None:  # rare: only the node's presence, not held yet, can say
                    threading.Thread(
                        target=self._answer_once_present,
                        args=(pending, reply),
                        name="paramdds-late-presence",
                        daemon=True,
                    ).start()
                else:
                    _answer(pending, reply, later)

    def _answer_once_present(self, pending: PendingCall, reply: Any) -> None:
        """Answer a refusal that only the node's presence can judge once this client holds it
        (a one-shot client makes its presence reader with the first copy, and a server's reply
        may come before its presence: CI's Fast DDS peer), waiting at most half the call's
        remaining time (the other half leaves this answer ahead of the call's own deadline),
        in a thread of its own so that no other reply waits. Without it then, the refusal is
        not believed."""
        node, now = pending.node, time.monotonic()
        until = now + (pending.call.deadline - now) / 2
        while self._presence_sample(node) is None and not pending.future.done():
            if time.monotonic() >= until or self._closing.wait(PRESENCE_POLL):
                break
        later = _refused_by_a_later_life(pending, reply, lambda: self._serving_life(node) or 0)
        _answer(pending, reply, bool(later))

    def _not_seen(self, node: str, waited: float, held: str = "") -> ParamddsError:
        """The error for a node not (or no longer) online after ``waited`` seconds."""
        state = self.presence(node)
        if state is Presence.OFFLINE:
            return UnavailableError(f"node {node!r} is offline (waited {waited:.2g} s){held}")
        why = self.watch().state().describe()
        also = self._mismatched()
        if state is Presence.ABSENT:
            waited_for = f"waited {waited:.2g} s"
            return UnavailableError(f"node {node!r} is not present ({why}; {waited_for}){held}{also}")
        return CallTimeoutError(f"node {node!r} not seen within {waited:.2g} s: {why}{held}{also}")

    def _outcome_unknown(self, node: str, waited: float) -> OutcomeUnknownError:
        """The error for a write sent and not answered within its caller's ``waited`` seconds."""
        state = self.presence(node)
        now = {
            Presence.OFFLINE: " (it is offline now)",
            Presence.ABSENT: f" (it is not present: {self.watch().state().describe()})",
        }.get(state, "")
        return OutcomeUnknownError(
            f"outcome unknown: no answer from node {node!r}{now} within {waited:g} s of sending the "
            "request, so it may or may not have been applied; its deadline has passed, so the node "
            "will not apply it from now on (with clocks in sync): `get` shows the outcome"
            + self._mismatched()
        )

    def _mismatched(self) -> str:
        """A note for a failed call when peers were refused for their type or QoS (see :mod:`.peers`)."""
        found = peer_mismatches(self.participant)
        if not found:
            return ""
        n = len(found)
        return f" ({n} DDS peer endpoint(s) do not match ours and are ignored, e.g. {found[0].message()})"

    # -- replies ----------------------------------------------------------------------

    @staticmethod
    def _check(reply: Any) -> None:
        if reply.code:
            raise error_for(reply.code, reply.reason or reply.code)

    def list_result(self, reply: Any) -> ListResult:
        self._check(reply)
        return ListResult(tuple(reply.names), tuple(reply.prefixes))

    def get_reply(self, reply: Any) -> GetReply:
        self._check(reply)
        results = []
        for r in reply.results:
            code = code_of(r.code)
            results.append(
                GetResult(
                    name=r.name,
                    value=None if code else value_from_wire(r.value),
                    descriptor=descriptor_from_wire(r.descriptor[0]) if r.descriptor else None,
                    code=code,
                    reason=r.reason,
                    last_change=last_change_from_wire(r.last_change[0]) if r.last_change else None,
                )
            )
        return GetReply(reply.node_id, reply.revision, tuple(results), reply.incarnation)

    def set_reply(self, reply: Any) -> SetReply:
        self._check(reply)
        results = tuple(SetResult(r.name, r.successful, r.reason, code_of(r.code)) for r in reply.results)
        return SetReply(reply.node_id, reply.revision, results, reply.incarnation)

    def history_page(self, reply: Any) -> tuple[bool, HistoryPage]:
        self._check(reply)
        return page_from_wire(reply)

    # -- presence -------------------------------------------------------------------
    #
    # The presence reader is never drained by the dispatcher: Cyclone keeps each
    # instance's last sample serialized, and we decode only the presence instance of
    # the node asked about (lookup_instance + read). Taking every ParameterEvents
    # sample instead would make each client decode the whole system's state.

    def _presence_of(self, node: str) -> NodeInfo | None:
        sample = self._presence_sample(node)
        return None if sample is None else _node_info(sample)

    def _presence_sample(self, node: str) -> Any:
        """The latest presence sample this client holds of ``node`` (None: none)."""
        watch = self.watch()
        handle = self.presence_reader.lookup_instance(wire.ParameterEvent(node_id=node, name=""))
        if handle is None:
            return None
        try:
            samples: list[Any] = self.presence_reader.read(
                N=self._transport.samples_per_instance, instance_handle=handle
            )
        except DDSException:
            # the handle is process-wide: another entity here may know the key while
            # this reader holds no such instance (PRECONDITION_NOT_MET)
            return None
        watch.note_read(s.sample_info for s in samples)
        samples = self._believed(samples)
        return samples[-1] if samples else None

    def _serving_life(self, node: str, since_first_copy: bool = True) -> int | None:
        """The server life (incarnation) serving ``node`` now, as its presence says (0: none
        online; None: this client holds no presence of it yet). ``since_first_copy``: asked
        when a reply came, about a call whose first copy found no presence; then only a life
        that is the one this client ever saw of the node (no gap in its presence: not alive,
        then alive again) counts, else 0."""
        sample = self._presence_sample(canonical_node_id(node))
        if sample is None:
            return None
        if _node_info(sample) is None:
            return 0
        info = sample.sample_info
        if info.instance_state != InstanceState.Alive:
            return 0
        if since_first_copy and (info.disposed_generation_count or info.no_writers_generation_count):
            return 0
        return int(sample.incarnation)

    def _believed(self, samples: list[Any]) -> list[Any]:
        """Secure mode: the presence samples whose writers may write their node's partition
        (a sample without data, which names no node, says nothing and is dropped)."""
        return self._transport.believed(self.presence_reader, samples)

    def nodes(self) -> list[NodeInfo]:
        """Every node whose presence this client holds (alive or not), sorted by name."""
        watch = self.watch()
        samples: list[Any] = self.presence_reader.read(N=_READ_ALL)
        watch.note_read(s.sample_info for s in samples)
        # a node's samples come oldest first, so its last presence wins; samples without data
        # (a node its server stopped hosting) and parameter samples give None
        found = (_node_info(s) for s in self._believed(samples))
        latest = {n.node: n for n in found if n is not None}
        return sorted(latest.values(), key=lambda n: n.node)

    def node_info(self, node: str) -> NodeInfo | None:
        return self._presence_of(canonical_node_id(node))

    def discovery(self) -> DiscoveryState:
        """How far this client's discovery of the system has got (see :mod:`.discovery`)."""
        return self.watch().state()

    def ignore_writer(self, writer: Any) -> None:
        """Leave a ``ParameterEvents`` writer of this process out of :meth:`discovery`
        (see :meth:`DiscoveryWatch.ignore`)."""
        self.watch().ignore(writer)

    def presence(self, node: str) -> Presence:
        """ONLINE, OFFLINE, ABSENT (discovery settled without it) or UNKNOWN (it may yet appear).

        The one place that decides whether a node "is not present": the calls, the
        CLI and a web console all ask this.
        """
        info = self._presence_of(canonical_node_id(node))
        if info is not None:
            return Presence.ONLINE if info.online else Presence.OFFLINE
        return Presence.ABSENT if self.watch().settled() else Presence.UNKNOWN

    def wait_for_node(self, node: str, timeout: float) -> NodeInfo:
        """Block until ``node`` is online, for up to ``timeout`` seconds (checks every
        :data:`PRESENCE_POLL` seconds: a start-up wait, not a data path)."""
        node = canonical_node_id(node)
        deadline = time.monotonic() + timeout
        while True:
            info = self._presence_of(node)
            if info is not None and info.online:
                return info
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise self._not_seen(node, timeout)
            self.watch().state()  # moves discovery on: asks again (a probe) when nobody answered
            self._closing.wait(min(remaining, PRESENCE_POLL))
            if self._closing.is_set():
                raise UnavailableError("the client was closed")


def _node_info(sample: Any) -> NodeInfo | None:
    """The presence carried by a ParameterEvents sample, or None for a parameter sample."""
    info = sample.sample_info
    if not info.valid_data or is_malformed(sample) or sample.kind != wire.EVENT_PRESENCE:
        return None
    online = info.instance_state == InstanceState.Alive
    tags = sample.value.string_array_value  # the server's tags, if it writes any
    return NodeInfo(
        sample.node_id,
        online,
        sample.host,
        sample.pid,
        sample.revision,
        sample.parameter_count,
        request_filter_of(tags),
        sample.incarnation,
        origin_of(tags),
        status_of(tags),
    )


def _refused_by_a_later_life(
    pending: PendingCall, reply: Any, serving_life: Callable[[], int | None]
) -> bool | None:
    """Whether ``reply`` refuses a write from a server life other than the one it expected,
    after more than one copy went out (:meth:`~paramdds.core.call.Call.refused_by_a_later_life`).
    The life serving the node is the one seen when the first copy went out, else
    ``serving_life()`` (the one life this client has seen, asked only in this rare case;
    None: no presence of the node held yet, and then neither is the answer)."""
    call = pending.call
    if not call.write or call.copies < 2:  # the common case, before reading the reply
        return False
    refused = bool(reply.code) or not all(r.successful for r in reply.results)
    expected, answering = pending.message.expected_incarnation, reply.incarnation
    if not call.refused_by_a_later_life(expected, answering, refused, pending.serving_life):
        return False
    if pending.serving_life != 0:
        return True
    life = serving_life()
    return None if life is None else life != answering


def _answer(pending: PendingCall, reply: Any, later: bool) -> None:
    """Set ``reply`` on its call, or the error of a refusal by a later life (``later``); a call
    already ended (cancelled by an asyncio caller) is left as it is."""
    try:
        if later:
            pending.future.set_exception(_later_life(pending, reply))
        else:
            pending.future.set_result(reply)
    except InvalidStateError:
        pass


def _later_life(pending: PendingCall, reply: Any) -> OutcomeUnknownError:
    node = pending.node
    return OutcomeUnknownError(
        f"outcome unknown: node {node!r} restarted while the request was being sent again, and "
        f"its new server refused a copy ({reply.code or 'CONFLICT'}); an earlier copy may have been "
        "applied before the restart: `get` or `history` shows the outcome"
    )


def _expected(if_revision: int | Revision | None) -> Revision:
    """What a set request compares: (0, -1) nothing, (0, n) the revision alone."""
    if if_revision is None:
        return Revision(0, -1)
    expected = if_revision if isinstance(if_revision, Revision) else Revision(0, if_revision)
    incarnation, revision = expected
    if not (isinstance(incarnation, int) and isinstance(revision, int)):
        raise ParamddsError(f"if_revision must be an int or a Revision, got {if_revision!r}")
    if not expected.on_wire():
        raise ParamddsError(f"if_revision out of range: {if_revision!r}")
    return expected
