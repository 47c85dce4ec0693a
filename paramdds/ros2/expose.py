"""paramdds nodes exposed to ROS 2: the six parameter services and ``/parameter_events``.

Each exposed node gets an rclpy node of the same name (``robot/arm`` -> ``/robot/arm``)
in the bridge's enclave, with ``list_parameters``, ``get_parameters``,
``get_parameter_types``, ``describe_parameters``, ``set_parameters`` and
``set_parameters_atomically``; each call becomes a paramdds request (bounded by the
bridge's timeout). Answers follow rclpy's parameter services: an unknown name in a
get, describe or types request makes the whole answer empty. The node's changes, as
a paramdds monitor sees them, are published on ``/parameter_events`` under its name.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from typing import Any

from cyclonedds.domain import DomainParticipant

from ..core.descriptors import ParameterDescriptor
from ..core.values import Parameter
from ..dds.client import ParameterClient
from ..dds.monitor import EventKind, MonitorEvent, ParameterMonitor
from ..dds.qos import QosProfiles
from ..errors import ParamddsError
from .messages import descriptor_to_ros, value_from_ros, value_to_ros
from .rosside import RosSide

log = logging.getLogger(__name__)


@dataclass
class Exposed:
    node_id: str
    fqn: str
    ros_node: Any


class Exposer:
    """Serves the ROS 2 parameter services of the paramdds nodes :meth:`update` is given."""

    def __init__(
        self, ros: RosSide, participant: DomainParticipant, qos: QosProfiles, timeout: float
    ) -> None:
        from rcl_interfaces.msg import ParameterEvent
        from rclpy.qos import qos_profile_parameter_events

        self.ros = ros
        self.timeout = timeout
        self.client = ParameterClient(participant, qos, timeout=timeout)
        self.nodes: dict[str, Exposed] = {}
        self._refused: set[str] = set()  # node ids ROS 2 does not accept as names
        self._lock = threading.Lock()
        self._publisher = ros.node.create_publisher(
            ParameterEvent, "/parameter_events", qos_profile_parameter_events
        )
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
        from rcl_interfaces.msg import Parameter as RosParameter
        from rcl_interfaces.msg import ParameterEvent

        msg = ParameterEvent(node=exposed.fqn)
        msg.stamp = exposed.ros_node.get_clock().now().to_msg()
        if event.event is EventKind.DELETED:
            msg.deleted_parameters = [RosParameter(name=event.name)]
        else:
            assert event.value is not None
            p = RosParameter(name=event.name, value=value_to_ros(event.value))
            if event.event is EventKind.ADDED:
                msg.new_parameters = [p]
            else:
                msg.changed_parameters = [p]
        try:
            self._publisher.publish(msg)
        except Exception:
            log.debug("publishing a parameter event of %s failed", event.node, exc_info=True)

    def close(self) -> None:
        for node_id in list(self.nodes):
            self._remove(node_id)
        self.monitor.close()
        self.client.close()


def _refuse(request: Any, response: Any, reason: str) -> None:
    """A paramdds failure (node offline, timeout) as ROS 2 would show it: refused sets, empty reads."""
    from rcl_interfaces.msg import SetParametersResult

    if hasattr(response, "results"):
        response.results = [SetParametersResult(successful=False, reason=reason) for _ in request.parameters]
    elif hasattr(response, "result") and hasattr(request, "parameters"):
        response.result = SetParametersResult(successful=False, reason=reason)
