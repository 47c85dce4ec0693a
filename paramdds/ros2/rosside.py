"""The bridge's side of the ROS 2 graph: one rclpy context, node and executor of its own.

The context is private (``rclpy.init(context=...)``), so the bridge coexists with any
other rclpy use in the process, and it joins ROS 2 domain ``domain`` (``ROS_DOMAIN_ID``
when None), which may differ from the paramdds domain. Its nodes carry the enclave
:data:`ENCLAVE`: a bridge never mirrors a node of that enclave (itself, the nodes it
exposes, another bridge's), which is what keeps two bridges from looping a node.

The side's participant runs without XTypes type lookup (Fast DDS's participant property
``fastdds.type_propagation`` = ``disabled``, :mod:`.fastdds_profile`): it matches every
remote endpoint by type name, asks no peer for a type, and announces no type information of
its own. Type lookup is to be avoided twice over:

* a peer answering requests meant for another can derail it;
* Fast DDS 3.2 crashes in it (SIGSEGV) when many endpoints of a type it does not know are
  discovered at once (:mod:`.fastdds_profile` says how). A graph of N nodes makes N
  ``/rosout`` writers discovered in one burst: with ``Log`` unknown, bridge starts beside
  100 nodes crashed there now and then (seen under CPU starvation; the core's pending type
  was ``rcl_interfaces::msg::dds_::Log_``), and any type the bridge does not have (your
  nodes' message types) can do the same.

Fast DDS reads that property once per process, with its first ROS 2 participant. Where the
side is not that participant (ROS 2 was used in this process before), it falls back on
knowing the common types beforehand: right after its node exists it makes a client of each
parameter service type and a publisher of each message type every ROS 2 node has an
endpoint of (``/rosout``'s ``Log``, ``/clock``'s ``Clock``), on hidden names, so Fast DDS
knows those types before it discovers any remote endpoint of them.

Service calls are made from any thread (a mirrored node's worker, the sync pool) and
wait on their future with a bounded timeout. The bridge's own node (its service clients
and its ``/parameter_events`` subscription, whose callbacks are all short) is spun by a
single-threaded executor; the nodes it exposes, whose service callbacks wait on paramdds
calls, by a multi-threaded one of their own, made with the first of them. rclpy's
multi-threaded executor loops over its futures while its pool runs a callback: for the
bridge's node it made a forwarded set take 3-4 ms at the median and 0.2-0.5 s at p99,
against 1.5 ms and 5.5 ms single-threaded (a set of one double, through the bridge, on
this 2-core machine). A ROS 2 node that never answers holds only the caller that asked.
"""

from __future__ import annotations

import logging
import threading
import time
import weakref
from collections.abc import Callable
from typing import Any

from ..errors import ErrorCode, ParamddsError
from .fastdds_profile import type_lookup_off

log = logging.getLogger(__name__)


class Unanswered(ParamddsError):
    """A service call that was sent and got no answer (TIMEOUT) or failed after it was sent:
    the node may have acted on it (for a set: OUTCOME_UNKNOWN, see :func:`.mirror.unanswered`)."""


ENCLAVE = "/paramdds_bridge"  # the enclave of every node a bridge creates
TYPES_SERVICE = "/_paramdds_bridge/types"  # hidden (a leading _): the endpoints that register types


def _messages() -> list[Any]:
    """The message types of the endpoints every ROS 2 node has besides its parameter services and
    ``/parameter_events`` (which the bridge's own node has too): ``/rosout`` (``Log``) and, with
    ``use_sim_time``, ``/clock`` (``Clock``)."""
    from rcl_interfaces.msg import Log
    from rosgraph_msgs.msg import Clock

    return [Log, Clock]


def _kinds() -> list[Any]:
    """The parameter services' types (each registers its request and reply types)."""
    from rcl_interfaces import srv

    return [
        srv.ListParameters,
        srv.GetParameters,
        srv.DescribeParameters,
        srv.SetParameters,
        srv.SetParametersAtomically,
        srv.GetParameterTypes,
    ]


class RosSide:
    """An rclpy context and one node named ``name``, spun by an executor of its own; the nodes
    made by :meth:`create_node` are spun by a multi-threaded executor of ``threads``."""

    def __init__(self, domain: int | None, name: str = "paramdds_bridge", threads: int = 8) -> None:
        quiet_imports()
        import rclpy
        from rclpy.callback_groups import ReentrantCallbackGroup
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self._rclpy = rclpy
        self.context = Context()
        with type_lookup_off() as self.no_type_lookup:  # the participant is made with the first node
            rclpy.init(args=["--ros-args", "--enclave", ENCLAVE], context=self.context, domain_id=domain)
            self.node = rclpy.create_node(
                name,
                context=self.context,
                start_parameter_services=False,
                enable_rosout=False,
            )
        self.domain = self.context.get_domain_id()
        self.clients_group = ReentrantCallbackGroup()  # responses are handled concurrently
        self._type_clients = [self.client(k, f"{TYPES_SERVICE}/{k.__name__.lower()}") for k in _kinds()]
        self._type_publishers = [
            self.node.create_publisher(m, f"{TYPES_SERVICE}/{m.__name__.lower()}", 1) for m in _messages()
        ]
        self._pool_threads = threads
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._exposed: Any = None  # the multi-threaded executor of the nodes of create_node
        self._lock = threading.Lock()
        self._threads = [self._spinning(self.executor, "paramdds-ros2-executor")]

    @staticmethod
    def _spinning(executor: Any, name: str) -> threading.Thread:
        def spin() -> None:
            try:
                executor.spin()
            except Exception:  # the context was shut down under it: closing
                log.debug("the ROS 2 executor %s stopped", name, exc_info=True)

        thread = threading.Thread(target=spin, name=name, daemon=True)
        thread.start()
        return thread

    @property
    def fqn(self) -> str:
        return str(self.node.get_fully_qualified_name())

    def create_node(self, name: str, namespace: str) -> Any:
        """Another node of this context (an exposed paramdds node), spun by the multi-threaded
        executor (its service callbacks wait on paramdds calls)."""
        from rclpy.executors import MultiThreadedExecutor

        node = self._rclpy.create_node(
            name,
            namespace=namespace,
            context=self.context,
            start_parameter_services=False,
            enable_rosout=False,
        )
        with self._lock:
            if self._exposed is None:
                self._exposed = MultiThreadedExecutor(num_threads=self._pool_threads, context=self.context)
                self._threads.append(self._spinning(self._exposed, "paramdds-ros2-exposed"))
            self._exposed.add_node(node)
        return node

    def destroy_node(self, node: Any) -> None:
        with self._lock:
            exposed = self._exposed
        if exposed is not None:
            exposed.remove_node(node)
        node.destroy_node()

    def graph(self) -> dict[str, str]:
        """Every ROS 2 node in the graph: fully qualified name -> enclave."""
        out: dict[str, str] = {}
        for name, ns, enclave in self.node.get_node_names_and_namespaces_with_enclaves():
            out[fqn_of(name, ns)] = enclave
        return out

    def event_publishers(self) -> dict[str, frozenset[bytes]]:
        """Each node's ``/parameter_events`` writers (their GIDs): a new one means a restart."""
        out: dict[str, set[bytes]] = {}
        for info in self.node.get_publishers_info_by_topic("/parameter_events"):
            out.setdefault(fqn_of(info.node_name, info.node_namespace), set()).add(bytes(info.endpoint_gid))
        return {k: frozenset(v) for k, v in out.items()}

    def client(self, srv_type: Any, service: str) -> Any:
        return self.node.create_client(srv_type, service, callback_group=self.clients_group)

    def destroy_client(self, client: Any) -> None:
        """Destroy a client of :meth:`client` and forget it in its callback group, where rclpy
        keeps a dead weak reference for every client destroyed (ros2/rclpy#1356): the bridge
        makes and drops four clients per ROS 2 node start, and that set was its steady growth
        under host restarts."""
        try:
            self.node.destroy_client(client)
        finally:
            self.clients_group.entities.discard(weakref.ref(client))

    def call(self, client: Any, request: Any, timeout: float) -> Any:
        """Call a service and wait at most ``timeout`` seconds. UNAVAILABLE when the service is not
        there (nothing was sent); :class:`Unanswered` once the request went out (TIMEOUT, or the
        call failed after it was sent)."""
        if not self._ready(client, min(timeout, 2.0)):
            raise ParamddsError(
                f"the ROS 2 service {client.srv_name} is not available", code=ErrorCode.UNAVAILABLE
            )
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _f: done.set())
        if not done.wait(timeout):
            client.remove_pending_request(future)
            raise Unanswered(
                f"the ROS 2 node did not answer {client.srv_name} within {timeout:g} s "
                "(busy in a callback, or gone)",
                code=ErrorCode.TIMEOUT,
            )
        exc = future.exception()
        if exc is not None:
            raise Unanswered(f"{client.srv_name} failed after it was sent: {exc}", code=ErrorCode.UNAVAILABLE)
        return future.result()

    @staticmethod
    def _ready(client: Any, timeout: float) -> bool:
        """Whether the client matched its service within ``timeout`` (rclpy's own
        ``wait_for_service`` sleeps in steps of 0.25 s: a bridge syncing 300 nodes
        would spend most of its time there)."""
        deadline = time.monotonic() + timeout
        while not client.service_is_ready():
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.005)
        return True

    def subscribe_events(self, callback: Callable[[Any], None], on_lost: Callable[[], None]) -> Any:
        """Follow ``/parameter_events`` (one callback at a time, in order); ``on_lost`` runs when
        DDS reports lost samples, where the middleware can tell."""
        from rcl_interfaces.msg import ParameterEvent
        from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
        from rclpy.event_handler import SubscriptionEventCallbacks
        from rclpy.qos import qos_profile_parameter_events

        group = MutuallyExclusiveCallbackGroup()
        events = SubscriptionEventCallbacks(message_lost=lambda _info: on_lost())

        def subscribe(**extra: Any) -> Any:
            return self.node.create_subscription(
                ParameterEvent,
                "/parameter_events",
                callback,
                qos_profile_parameter_events,
                callback_group=group,
                **extra,
            )

        try:
            return subscribe(event_callbacks=events)
        except Exception as exc:  # the middleware cannot report lost samples: periodic resync only
            log.info("lost /parameter_events samples cannot be detected here (%s)", exc)
            return subscribe()

    def close(self) -> None:
        with self._lock:
            executors = [e for e in (self._exposed, self.executor) if e is not None]
        for executor in executors:
            try:
                executor.shutdown(timeout_sec=2.0)
            except Exception:
                log.debug("a ROS 2 executor did not shut down cleanly", exc_info=True)
        try:
            self.node.destroy_node()
        finally:
            if self.context.ok():
                self._rclpy.shutdown(context=self.context)
        for thread in self._threads:
            thread.join(timeout=2.0)


def quiet_imports() -> None:
    """Import rclpy's type support now, without the DeprecationWarning its parser's ``lark``
    raises on import (``sre_parse``): under ``-W error`` it would fail the first message."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import rosidl_generator_py  # noqa: F401


def fqn_of(name: str, namespace: str) -> str:
    """``/ns/name`` from a node's name and namespace."""
    ns = namespace.rstrip("/")
    return f"{ns}/{name}" if ns.startswith("/") else f"/{ns}/{name}" if ns else f"/{name}"
