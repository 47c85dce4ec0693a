"""Per-node partitions in secure mode, and the check DDS cannot make.

DDS Security grants name topics and partitions, never key values. So in secure mode
every sample about a node travels in the partition named by that node id:

* **writers** use exact node ids: a client's request writer for node N is in
  partition ``N`` (one publisher and writer per target node and topic, made on first
  use); a server's state and reply writers are in the partitions of the nodes it hosts.
  A writer outside its identity's grants is refused by DDS when it is created
  (``NOT_ALLOWED_BY_SECURITY``), here and by every peer that checks its permissions;
* **readers** use exact node ids where they know them (a server's request readers:
  its nodes) and the identity's node globs otherwise (monitors, reply and presence
  readers): ``robot1*`` reads every partition that glob matches;
* a reader also drops a sample whose ``node_id`` is not among its writer's partitions
  (:meth:`Scope.allows`): a server granted ``robot1`` could otherwise write state that
  names ``robot2`` inside its own partition. The writer's partitions come from DDS's
  discovery data (signed and checked against its permissions), cached per writer:
  Cyclone never changes an existing entity's partitions.

Nothing here is used without an identity: the default wire has no partitions.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from ..core.names import canonical_node_id
from ..errors import NotPermittedError, ParamddsError
from .identity import Identity

__all__ = ["Scope", "guard_raw", "guard_samples", "not_permitted", "permitted", "scope_of"]

_MASK = (1 << 64) - 1
_ACTIONS = {"SetParametersRequest": "set", "GetParametersRequest": "get", "ListParametersRequest": "list"}


def scope_of(participant: Any) -> Scope | None:
    """The participant's secure scope, or None when it is not secure."""
    scope = getattr(participant, "_paramdds_scope", None)
    return scope if isinstance(scope, Scope) else None


def not_permitted(what: str, identity: Identity, exc: BaseException) -> NotPermittedError:
    return NotPermittedError(
        f"{what}: not permitted for identity {identity.name!r} (role {identity.role}, nodes "
        f"{' '.join(identity.nodes)}); DDS Security refused it ({exc})"
    )


class Scope:
    """The publishers, subscribers and partition check of one secure participant."""

    def __init__(self, participant: Any, identity: Identity) -> None:
        self.participant = participant
        self.identity = identity
        self._lock = threading.Lock()
        self._publishers: dict[frozenset[str], Any] = {}
        self._subscribers: dict[frozenset[str], Any] = {}
        self._writers: dict[tuple[str, str, int], Any] = {}
        self._partitions: dict[int, frozenset[str]] = {}  # publication handle -> its partitions
        self._opened: set[str] = set()

    # -- entities ------------------------------------------------------------------------

    def publisher(self, nodes: Iterable[str]) -> Any:
        """A publisher in exactly these node-id partitions (shared per set)."""
        from cyclonedds.pub import Publisher

        return self._in_partitions(self._publishers, Publisher, frozenset(nodes))

    def subscriber(self, nodes: Iterable[str] | None = None) -> Any:
        """A subscriber in these node-id partitions, or in the identity's globs (None)."""
        from cyclonedds.sub import Subscriber

        return self._in_partitions(
            self._subscribers, Subscriber, frozenset(self.identity.nodes if nodes is None else nodes)
        )

    def _in_partitions(self, made: dict[frozenset[str], Any], kind: Any, key: frozenset[str]) -> Any:
        """The ``kind`` (Publisher or Subscriber) in the partitions ``key``, made once per set."""
        from cyclonedds.qos import Policy, Qos

        with self._lock:
            found = made.get(key)
            if found is None:
                found = made[key] = kind(self.participant, qos=Qos(Policy.Partition(sorted(key))))
            return found

    def writer(self, topic: str, node: str, qos: Any, *, opening: Callable[[str], None] | None = None) -> Any:
        """The writer of topic ``topic`` in node ``node``'s partition (made once per topic, node, QoS).

        ``opening(topic)`` runs first, once per topic (the client opens its reply reader).
        Raises NotPermittedError when DDS Security refuses the topic or the writer.
        """
        from cyclonedds.core import DDSException
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic

        from ..dds.wire import types as wire

        key = (topic, node, id(qos))
        found = self._writers.get(key)
        if found is None:
            action = _ACTIONS.get(topic, topic)
            try:
                if opening is not None and topic not in self._opened:
                    opening(topic)
                    self._opened.add(topic)
                found = DataWriter(
                    self.publisher([node]), Topic(self.participant, topic, wire.TOPICS[topic]), qos
                )
            except DDSException as exc:
                raise not_permitted(f"{action} on node {node!r}", self.identity, exc) from exc
            self._writers[key] = found
        return found

    def reader(self, topic: Any, qos: Any, nodes: Iterable[str] | None = None, **kwargs: Any) -> Any:
        """A reader in ``nodes``' partitions or the identity's globs; NOT_PERMITTED when refused."""
        from cyclonedds.core import DDSException
        from cyclonedds.sub import DataReader

        try:
            return DataReader(self.subscriber(nodes), topic, qos, **kwargs)
        except DDSException as exc:
            raise not_permitted(f"reading {topic.name}", self.identity, exc) from exc

    # -- the partition check ---------------------------------------------------------------

    def writer_partitions(self, reader: Any, handle: int) -> frozenset[str]:
        """The partitions of the writer ``handle`` matched by ``reader`` (empty when unknown)."""
        handle &= _MASK
        found = self._partitions.get(handle)
        if found is not None:
            return found
        from cyclonedds.qos import Policy

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
        """Whether a sample about ``node_id`` from the writer in ``info`` may be believed."""
        handle = int(getattr(info, "publication_handle", 0) or 0)
        if handle == 0:
            return not getattr(info, "valid_data", True)  # a state change DDS made itself
        try:
            node = canonical_node_id(node_id)
        except ParamddsError:
            return False
        return node in self.writer_partitions(reader, handle)


@contextmanager
def permitted(scope: Scope | None, what: str) -> Iterator[None]:
    """In secure mode, turn DDS Security's refusal to create an entity into NotPermittedError."""
    from cyclonedds.core import DDSException

    try:
        yield
    except DDSException as exc:
        if scope is None:
            raise
        raise not_permitted(what, scope.identity, exc) from exc


Handler = Callable[[Sequence[Any]], None]


def guard_samples(scope: Scope | None, reader: Any, handler: Handler) -> Handler:
    """``handler`` for samples of ``reader`` (binding samples with ``sample_info``), minus those
    whose ``node_id`` is not among their writer's partitions; unchanged when not secure."""
    if scope is None:
        return handler

    def guarded(samples: Sequence[Any]) -> None:
        # samples without data (an unregistered or disposed instance) carry no node_id;
        # every handler skips them
        handler(
            [
                s
                for s in samples
                if not s.sample_info.valid_data or scope.allows(reader, s.node_id, s.sample_info)
            ]
        )

    return guarded


def guard_raw(scope: Scope | None, reader: Any, handler: Handler) -> Handler:
    """The same for ``Dispatcher.add_raw`` handlers, which get ``(decoded, info)`` pairs."""
    if scope is None:
        return handler

    def guarded(samples: Sequence[Any]) -> None:
        handler([(s, info) for s, info in samples if s is None or scope.allows(reader, s.node_id, info)])

    return guarded
