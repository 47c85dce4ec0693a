"""paramdds nodes exposed to ROS 2: the six parameter services and ``/parameter_events``.

Each exposed node gets an rclpy node of the same name (``robot/arm`` -> ``/robot/arm``)
in the bridge's enclave, with ``list_parameters``, ``get_parameters``,
``get_parameter_types``, ``describe_parameters``, ``set_parameters`` and
``set_parameters_atomically``; each call becomes a paramdds request (bounded by the
bridge's timeout). Answers follow rclpy's parameter services: an unknown name in a
get, describe or types request makes the whole answer empty. The node's changes, as
a paramdds monitor sees them, are published on ``/parameter_events`` under its name,
one message per change as rclpy sends them: the parameters of one set (an atomic set's
every parameter) share a revision, and a message goes out when the node's next change
begins or :data:`GROUP_WAIT` after the last of its parameters arrived (a server writes
one change's parameters back to back). A deletion carries no revision of its own (it is
a dispose): it joins the change being gathered.

A set made through these services is recorded by the paramdds node with ``via`` ros2 and
``who`` :data:`ROS2_CALLER`, unverified: rclpy hands a service callback the request
without its header, and the header it takes exposes the sequence number only (not the
writer GUID that would name the caller through the ROS graph), so the calling ROS 2
node is not known here.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Any

from cyclonedds.domain import DomainParticipant

from ..core.descriptors import ParameterDescriptor
from ..core.origin import Via
from ..core.values import Parameter
from ..dds.client import ParameterClient
from ..dds.monitor import EventKind, MonitorEvent, ParameterMonitor
from ..dds.qos import QosProfiles
from ..errors import ParamddsError
from .messages import descriptor_to_ros, value_from_ros, value_to_ros
from .rosside import RosSide

log = logging.getLogger(__name__)

ROS2_CALLER = "ros2"  # who a write through an exposed node claims to be (unverified)
GROUP_WAIT = 0.02  # seconds without more of a node's change before its message goes out


@dataclass
class Exposed:
    node_id: str
    fqn: str
    ros_node: Any


@dataclass
class _Gathering:
    """The events of one change of one node, not yet published."""

    exposed: Exposed
    revision: int | None  # None while it holds deletions only (they carry no revision)
    events: list[MonitorEvent]
    last: float  # time.monotonic() of the last event


class Exposer:
    """Serves the ROS 2 parameter services of the paramdds nodes :meth:`update` is given."""

    def __init__(
        self, ros: RosSide, participant: DomainParticipant, qos: QosProfiles, timeout: float
    ) -> None:
        from rcl_interfaces.msg import ParameterEvent
        from rclpy.qos import qos_profile_parameter_events

        self.ros = ros
        self.timeout = timeout
        # a ROS 2 tool's write, recorded via ros2 (the caller is not known: see the module doc)
        self.client = ParameterClient(participant, qos, timeout=timeout, as_=ROS2_CALLER, via=Via.ROS2)
        self.nodes: dict[str, Exposed] = {}
        self._refused: set[str] = set()  # node ids ROS 2 does not accept as names
        self._lock = threading.Lock()
        self._publisher = ros.node.create_publisher(
            ParameterEvent, "/parameter_events", qos_profile_parameter_events
        )
        self._gathering: dict[str, _Gathering] = {}  # node id -> its change being gathered
        self._events = threading.Condition()
        self._closed = False
        self._sender = threading.Thread(target=self._send_loop, name="paramdds-ros2-events", daemon=True)
        self._sender.start()
        self.monitor = ParameterMonitor(participant, qos, on_event=self._on_event)

    def update(self, wanted: dict[str, Any]) -> None:
        with self._lock:
            current = set(self.nodes)
        for node_id in current - wanted.keys():
            self._remove(node_id)
        for node_id in wanted.keys() - current - self._refused:
            self._add(node_id)

    def _add(self, node_id: str) -> None:
        ns, _, name = ("/" + node_id).rpartition("/")
        try:
            ros_node = self.ros.create_node(name, ns or "/")
        except Exception as exc:  # a paramdds node id that is no valid ROS 2 name
            log.warning("cannot expose %r to ROS 2: %s", node_id, exc)
            self._refused.add(node_id)  # said once, not tried again every look
            return
        self._services(ros_node, node_id)
        with self._lock:
            self.nodes[node_id] = Exposed(node_id, "/" + node_id, ros_node)
        log.info("exposing %s to ROS 2", node_id)

    def _remove(self, node_id: str) -> None:
        with self._lock:
            exposed = self.nodes.pop(node_id, None)
        if exposed is not None:
            self.ros.destroy_node(exposed.ros_node)

    def _services(self, ros_node: Any, node_id: str) -> None:
        from rcl_interfaces import srv
        from rclpy.callback_groups import ReentrantCallbackGroup
        from rclpy.qos import qos_profile_parameters

        group = ReentrantCallbackGroup()
        base = ros_node.get_fully_qualified_name()
        handlers = {
            "list_parameters": (srv.ListParameters, self._list),
            "get_parameters": (srv.GetParameters, self._get),
            "get_parameter_types": (srv.GetParameterTypes, self._types),
            "describe_parameters": (srv.DescribeParameters, self._describe),
            "set_parameters": (srv.SetParameters, self._set),
            "set_parameters_atomically": (srv.SetParametersAtomically, self._set_atomically),
        }
        for service, (kind, handler) in handlers.items():

            def call(request: Any, response: Any, handler: Any = handler) -> Any:
                try:
                    handler(node_id, request, response)
                except ParamddsError as exc:
                    log.debug("%s on %s failed: %s", type(request).__name__, node_id, exc.message)
                    _refuse(request, response, exc.message)
                return response

            ros_node.create_service(
                kind, f"{base}/{service}", call, qos_profile=qos_profile_parameters, callback_group=group
            )

    # -- the six services (rclpy's answers) -------------------------------------------

    def _list(self, node_id: str, request: Any, response: Any) -> None:
        listed = self.client.list(node_id, list(request.prefixes), int(request.depth))
        response.result.names = list(listed.names)
        response.result.prefixes = list(listed.prefixes)

    def _found(self, node_id: str, names: list[str]) -> list[Any] | None:
        reply = self.client.get(node_id, names, with_descriptors=True)
        if reply.missing():
            return None  # rclpy: an unknown name empties the whole answer
        return list(reply.results)

    def _get(self, node_id: str, request: Any, response: Any) -> None:
        found = self._found(node_id, list(request.names))
        response.values = [] if found is None else [value_to_ros(r.value) for r in found]

    def _types(self, node_id: str, request: Any, response: Any) -> None:
        found = self._found(node_id, list(request.names))
        response.types = [] if found is None else [int(r.value.type) for r in found]

    def _describe(self, node_id: str, request: Any, response: Any) -> None:
        found = self._found(node_id, list(request.names))
        response.descriptors = (
            []
            if found is None
            else [descriptor_to_ros(r.descriptor or ParameterDescriptor(r.name)) for r in found]
        )

    def _params(self, request: Any) -> list[Parameter]:
        return [Parameter(p.name, value_from_ros(p.value)) for p in request.parameters]

    def _set(self, node_id: str, request: Any, response: Any) -> None:
        from rcl_interfaces.msg import SetParametersResult

        reply = self.client.set(node_id, self._params(request))
        response.results = [
            SetParametersResult(successful=r.successful, reason=r.reason) for r in reply.results
        ]

    def _set_atomically(self, node_id: str, request: Any, response: Any) -> None:
        from rcl_interfaces.msg import SetParametersResult

        reply = self.client.set(node_id, self._params(request), atomic=True)
        failed = [r for r in reply.results if not r.successful]
        reason = next((f"{r.name}: {r.reason}" for r in failed if "atomic set failed" not in r.reason), "")
        if failed and not reason:
            reason = f"{failed[0].name}: {failed[0].reason}"
        response.result = SetParametersResult(successful=not failed, reason=reason)

    # -- /parameter_events ----------------------------------------------------------

    def _on_event(self, event: MonitorEvent) -> None:
        if event.event not in (EventKind.ADDED, EventKind.MODIFIED, EventKind.DELETED):
            return
        exposed = self.nodes.get(event.node)
        if exposed is None or (event.value is None and event.event is not EventKind.DELETED):
            return
        deleted = event.event is EventKind.DELETED
        with self._events:
            g = self._gathering.get(event.node)
            if g is not None and not deleted and g.revision not in (None, event.revision):
                self._publish(self._gathering.pop(event.node))  # the node's next change begins
                g = None
            if g is None:
                g = self._gathering[event.node] = _Gathering(exposed, None, [], 0.0)
            g.events.append(event)
            g.revision = g.revision if deleted else event.revision
            g.last = time.monotonic()
            self._events.notify()

    def _send_loop(self) -> None:
        """Publish each gathered change GROUP_WAIT after its last event."""
        with self._events:
            while not self._closed:
                if not self._gathering:
                    self._events.wait()
                    continue
                now = time.monotonic()
                due = [n for n, g in self._gathering.items() if now - g.last >= GROUP_WAIT]
                for node in due:
                    self._publish(self._gathering.pop(node))
                if self._gathering:
                    first = min(g.last for g in self._gathering.values())
                    self._events.wait(max(0.001, first + GROUP_WAIT - now))

    def _publish(self, g: _Gathering) -> None:
        """One ParameterEvent holding a whole change (called under ``_events``: in order)."""
        from rcl_interfaces.msg import Parameter as RosParameter
        from rcl_interfaces.msg import ParameterEvent

        msg = ParameterEvent(node=g.exposed.fqn)
        msg.stamp = g.exposed.ros_node.get_clock().now().to_msg()
        last: dict[str, MonitorEvent] = {e.name: e for e in g.events}  # one entry per name, as rclpy
        for event in last.values():
            if event.event is EventKind.DELETED:
                msg.deleted_parameters.append(RosParameter(name=event.name))
                continue
            assert event.value is not None
            p = RosParameter(name=event.name, value=value_to_ros(event.value))
            if event.event is EventKind.ADDED:
                msg.new_parameters.append(p)
            else:
                msg.changed_parameters.append(p)
        try:
            self._publisher.publish(msg)
        except Exception:
            log.debug("publishing a parameter event of %s failed", g.exposed.node_id, exc_info=True)

    def close(self) -> None:
        self.monitor.close()
        with self._events:
            self._closed = True
            self._gathering.clear()
            self._events.notify()
        self._sender.join(timeout=2.0)
        for node_id in list(self.nodes):
            self._remove(node_id)
        self.client.close()


def _refuse(request: Any, response: Any, reason: str) -> None:
    """A paramdds failure (node offline, timeout) as ROS 2 would show it: refused sets, empty reads."""
    from rcl_interfaces.msg import SetParametersResult

    if hasattr(response, "results"):
        response.results = [SetParametersResult(successful=False, reason=reason) for _ in request.parameters]
    elif hasattr(response, "result") and hasattr(request, "parameters"):
        response.result = SetParametersResult(successful=False, reason=reason)
