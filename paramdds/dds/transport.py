"""The transport: our participant, and how the roles make their endpoints on it.

:func:`~paramdds.dds.participant.make_participant` returns a :class:`Participant`: a
Cyclone ``DomainParticipant`` (every binding call takes it) that also holds what
paramdds keeps beside it: the ``Domain`` configured for it, its :class:`~.peers.PeerWatch`
and its :class:`Transport`. The roles (server, client, monitor, assigner) make every
reader and writer through :func:`transport_of`, and never ask whether it is secure.

**Plain** (:class:`Transport`): no partitions. A writer per topic is shared by every
node, readers read everything, every sample is believed.

**Secure** (:class:`SecureTransport`, with an identity): DDS Security grants name
topics and partitions, never key values. So every sample about a node travels in the
partition named by that node id:

* **writers** use exact node ids: a client's request writer for node N is in
  partition ``N`` (one publisher and writer per target node and topic, made on first
  use); a server's state and reply writers are in the partitions of the nodes it hosts.
  A writer outside its identity's grants is refused by DDS when it is created
  (``NOT_ALLOWED_BY_SECURITY``), here and by every peer that checks its permissions;
* **readers** use exact node ids where they know them (a server's request readers:
  its nodes) and the identity's node globs otherwise (monitors, reply and presence
  readers): ``robot1*`` reads every partition that glob matches;
* a reader also drops a sample whose ``node_id`` is not among its writer's partitions
  (:meth:`SecureTransport.allows`): a server granted ``robot1`` could otherwise write
  state that names ``robot2`` inside its own partition. The writer's partitions come
  from DDS's discovery data (signed and checked against its permissions), cached per
  writer: Cyclone never changes an existing entity's partitions.

The identity reaches this module as plain data (:class:`Grants`); loading one, the
keystore and the secure Cyclone build live in :mod:`paramdds.secure`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from cyclonedds.core import DDSException
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter, Publisher
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader, Subscriber

from ..core.names import canonical_node_id
from ..errors import NotPermittedError, ParamddsError
from .topics import make_topic
from .wire import types as wire

if TYPE_CHECKING:
    from cyclonedds.domain import Domain

    from .peers import PeerWatch

__all__ = [
    "HOSTS",
    "Grants",
    "Hosting",
    "Participant",
    "SecureTransport",
    "Transport",
    "Writers",
    "transport_of",
]

_MASK = (1 << 64) - 1
_ACTIONS = {"SetParametersRequest": "set", "GetParametersRequest": "get", "ListParametersRequest": "list"}
# the partition of ParameterEvents where plain servers claim the nodes they host (see Hosting)
HOSTS = "paramdds.hosts"
SECURE_DEPTH = 4  # secure mode: samples kept per instance by a reader that drops some (see believed)

Handler = Callable[[Sequence[Any]], None]


class Grants(Protocol):
    """What the transport needs of an identity (:class:`paramdds.secure.identity.Identity` is one)."""

    @property
    def path(self) -> Path: ...
    @property
    def name(self) -> str: ...
    @property
    def role(self) -> str: ...
    @property
    def nodes(self) -> tuple[str, ...]: ...

    def security_config(self, domain_id: int) -> str:
        """The Cyclone ``<Security>`` element; raises when the domain or library cannot do it."""
        ...


def not_permitted(what: str, grants: Grants, exc: BaseException) -> NotPermittedError:
    return NotPermittedError(
        f"{what}: not permitted for identity {grants.name!r} (role {grants.role}, nodes "
        f"{' '.join(grants.nodes)}); DDS Security refused it ({_refusal(exc)})"
    )


def _refusal(exc: BaseException) -> str:
    """What DDS said, without the binding's note of where (it names Python classes; ``what``
    says it for the user)."""
    if isinstance(exc, DDSException) and exc.code in DDSException.error_message_mapping:
        name, meaning = DDSException.error_message_mapping[exc.code]
        return f"[{name}] {meaning}"
    return str(exc)


class Participant(DomainParticipant):
    """A Cyclone participant with paramdds's own: its Domain, peer watch and transport."""

    def __init__(
        self, domain_id: int, qos: Qos, *, domain: Domain | None = None, grants: Grants | None = None
    ) -> None:
        from .peers import PeerWatch

        try:
            super().__init__(domain_id, qos=qos)
        except DDSException as exc:
            if grants is None:
                raise
            raise NotPermittedError(
                f"DDS Security refused identity {grants.path}: its certificate, key, governance or "
                f"permissions do not verify (signed by the keystore's CAs? expired? domain {domain_id} "
                f"granted?); run with CYCLONEDDS_URI tracing for details ({exc})"
            ) from exc
        self.domain = domain  # keeps the Domain (and so this participant) alive
        self.transport: Transport = Transport(self) if grants is None else SecureTransport(self, grants)
        self.peers: PeerWatch = PeerWatch(self)


def transport_of(participant: DomainParticipant) -> Transport:
    """The transport of ``participant``: its own, or the plain one for a bare Cyclone participant."""
    if isinstance(participant, Participant):
        return participant.transport
    return Transport(participant)


class Hosting:
    """Where a server's endpoints live: its publisher and subscriber, the nodes it may host,
    and where it claims them and looks for other processes' claims (its twins).

    Plain, ``claim_publisher`` and ``claim_subscriber`` are in the partition :data:`HOSTS`,
    where each server writes one presence sample per node it hosts (its *claim*) and reads
    the others' (only those: a twin reader in the state's partition would be sent every
    node's whole retained state at start, and every change after). Secure: no claim
    publisher, and the claim subscriber is the server's own: its partitions hold only its
    nodes' samples, so it reads presence there."""

    def __init__(
        self,
        publisher: Any,
        subscriber: Any,
        nodes: frozenset[str] | None,
        claims: tuple[Any, Any] | None = None,
    ) -> None:
        self.publisher = publisher
        self.subscriber = subscriber
        self.nodes = nodes  # None: any node
        self.claim_publisher: Any = claims[0] if claims else None
        self.claim_subscriber: Any = claims[1] if claims else subscriber

    def admit(self, node_id: str) -> None:
        """Raise NotPermittedError for a node this server was not created for (secure form)."""
        if self.nodes is not None and node_id not in self.nodes:
            raise NotPermittedError(
                f"node {node_id!r} is not among the node ids this secure server was created with"
            )


class Writers:
    """One role's writers (a client's requests, an assigner's assignments), made on first use:
    one per topic on the plain transport, one per topic and node on the secure one."""

    def __init__(self, transport: Transport, *, opening: Callable[[str], None] | None = None) -> None:
        self._transport = transport
        self._opening = opening  # runs once per topic before its first writer (a client's reply reader)
        self._made: dict[tuple[str, str, int], Any] = {}
        self._opened: set[str] = set()

    def early(self, topic: str, qos: Qos) -> Any:
        """The writer every node shares, made now; None on the secure transport, whose writers
        are one per node, made by :meth:`get` on first use."""
        return None if self._transport.writer_per_node else self.get(topic, "", qos)

    def get(self, topic: str, node: str, qos: Qos) -> Any:
        """The writer of ``topic`` for ``node`` (not thread-safe: callers hold their own lock)."""
        key = (topic, node if self._transport.writer_per_node else "", id(qos))
        found = self._made.get(key)
        if found is None:
            if self._opening is not None and topic not in self._opened:
                with self._transport.refused(f"{_ACTIONS.get(topic, topic)} on node {node!r}"):
                    self._opening(topic)
                self._opened.add(topic)
            found = self._made[key] = self._transport.writer(topic, node, qos)
        return found


class Transport:
    """The plain transport: no partitions; every endpoint is on the participant itself."""

    samples_per_instance = 1  # what a presence reader keeps and reads per node
    writer_per_node = False  # one writer of a topic serves every node

    def __init__(self, participant: DomainParticipant) -> None:
        self.participant = participant
        self._lock = threading.Lock()

    # -- entities ------------------------------------------------------------------------

    def hosting(self, nodes: Iterable[str] | None) -> Hosting:
        """A server's publisher and subscriber, for the nodes it will host (secure: required)."""
        hosts = Qos(Policy.Partition([HOSTS]))
        claims = (Publisher(self.participant, qos=hosts), Subscriber(self.participant, qos=hosts))
        return Hosting(self.participant, self.participant, None, claims)

    @contextmanager
    def refused(self, what: str) -> Iterator[None]:
        """Turn DDS Security's refusal to create an entity into NotPermittedError (secure form)."""
        yield

    def reader(self, topic: Any, qos: Qos, nodes: Iterable[str] | None = None, **kwargs: Any) -> Any:
        """A reader of ``topic`` (secure: in ``nodes``' partitions, or the identity's globs)."""
        return DataReader(self.participant, topic, qos, **kwargs)

    def history(self, qos: Qos) -> Qos:
        """``qos`` for a reader whose samples :meth:`believed` may drop (secure: a deeper history)."""
        return qos

    def writer(self, topic: str, node: str, qos: Qos) -> Any:
        """A new writer of ``topic`` for samples about ``node`` (secure: in its partition; plain:
        any node). Raises NotPermittedError when DDS Security refuses it. :class:`Writers`
        keeps a role's writers."""
        with self.refused(f"{_ACTIONS.get(topic, topic)} on node {node!r}"):
            return DataWriter(
                self._publisher_for(node), make_topic(self.participant, topic, wire.TOPICS[topic]), qos
            )

    def _publisher_for(self, node: str) -> Any:
        return self.participant

    # -- what a reader believes --------------------------------------------------------------

    def allows(self, reader: Any, node_id: str, info: Any) -> bool:
        """Whether a sample about ``node_id`` from the writer in ``info`` may be believed."""
        return True

    def guard(self, reader: Any, handler: Handler) -> Handler:
        """``handler`` for binding samples of ``reader``, minus those not believed."""
        return handler

    def guard_raw(self, reader: Any, handler: Handler) -> Handler:
        """The same for ``Dispatcher.add_raw`` handlers, which get ``(decoded, info)`` pairs."""
        return handler

    def believed(self, reader: Any, samples: list[Any]) -> list[Any]:
        """The samples read from ``reader`` that may be believed."""
        return samples


class SecureTransport(Transport):
    """The secure transport: per-node partitions and the writer-partition check."""

    samples_per_instance = SECURE_DEPTH  # a few per node, to skip one a writer had no right to write
    writer_per_node = True  # each in its node's partition

    def __init__(self, participant: DomainParticipant, grants: Grants) -> None:
        super().__init__(participant)
        self.grants = grants
        self._publishers: dict[frozenset[str], Any] = {}
        self._subscribers: dict[frozenset[str], Any] = {}
        self._partitions: dict[int, frozenset[str]] = {}  # publication handle -> its partitions

    def publisher(self, nodes: Iterable[str]) -> Any:
        """A publisher in exactly these node-id partitions (shared per set)."""
        return self._in_partitions(self._publishers, Publisher, frozenset(nodes))

    def subscriber(self, nodes: Iterable[str] | None = None) -> Any:
        """A subscriber in these node-id partitions, or in the identity's globs (None)."""
        key = frozenset(self.grants.nodes if nodes is None else nodes)
        return self._in_partitions(self._subscribers, Subscriber, key)

    def _in_partitions(self, made: dict[frozenset[str], Any], kind: Any, key: frozenset[str]) -> Any:
        """The ``kind`` (Publisher or Subscriber) in the partitions ``key``, made once per set."""
        with self._lock:
            found = made.get(key)
            if found is None:
                found = made[key] = kind(self.participant, qos=Qos(Policy.Partition(sorted(key))))
            return found

    def hosting(self, nodes: Iterable[str] | None) -> Hosting:
        if not nodes:
            raise NotPermittedError("in secure mode a server is created with its node ids (nodes=...)")
        scoped = frozenset(canonical_node_id(n) for n in nodes)
        return Hosting(self.publisher(scoped), self.subscriber(scoped), scoped)

    @contextmanager
    def refused(self, what: str) -> Iterator[None]:
        try:
            yield
        except DDSException as exc:
            raise not_permitted(what, self.grants, exc) from exc

    def reader(self, topic: Any, qos: Qos, nodes: Iterable[str] | None = None, **kwargs: Any) -> Any:
        with self.refused(f"reading {topic.name}"):
            return DataReader(self.subscriber(nodes), topic, qos, **kwargs)

    def history(self, qos: Qos) -> Qos:
        deeper: Qos = qos + Qos(Policy.History.KeepLast(SECURE_DEPTH))
        return deeper

    def _publisher_for(self, node: str) -> Any:
        return self.publisher([node])

    # -- the partition check ---------------------------------------------------------------

    def writer_partitions(self, reader: Any, handle: int) -> frozenset[str]:
        """The partitions of the writer ``handle`` matched by ``reader`` (empty when unknown)."""
        handle &= _MASK
        found = self._partitions.get(handle)
        if found is not None:
            return found
        try:
            data = reader.get_matched_publication_data(handle)
            policy = data.qos[Policy.Partition] if data is not None else None
        except Exception:  # the writer went away: nothing it wrote is trusted
            return frozenset()
        found = frozenset(policy.partitions) if policy is not None else frozenset()
        if len(self._partitions) > 65536:
            self._partitions.clear()
        self._partitions[handle] = found
        return found

    def allows(self, reader: Any, node_id: str, info: Any) -> bool:
        handle = int(getattr(info, "publication_handle", 0) or 0)
        if handle == 0:
            return not getattr(info, "valid_data", True)  # a state change DDS made itself
        try:
            node = canonical_node_id(node_id)
        except ParamddsError:
            return False
        return node in self.writer_partitions(reader, handle)

    def guard(self, reader: Any, handler: Handler) -> Handler:
        def guarded(samples: Sequence[Any]) -> None:
            # samples without data (an unregistered or disposed instance) carry no node_id;
            # every handler skips them
            handler(
                [
                    s
                    for s in samples
                    if not s.sample_info.valid_data or self.allows(reader, s.node_id, s.sample_info)
                ]
            )

        return guarded

    def guard_raw(self, reader: Any, handler: Handler) -> Handler:
        def guarded(samples: Sequence[Any]) -> None:
            handler([(s, info) for s, info in samples if s is None or self.allows(reader, s.node_id, info)])

        return guarded

    def believed(self, reader: Any, samples: list[Any]) -> list[Any]:
        # a sample without data, which names no node, says nothing and is dropped
        return [
            s for s in samples if s.sample_info.valid_data and self.allows(reader, s.node_id, s.sample_info)
        ]
