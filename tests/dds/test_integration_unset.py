"""A statically typed parameter declared without a value, on real Cyclone DDS.

rclcpp and rclpy let a node declare a parameter with a type and no value (issue 14);
the wire must carry that state: described with its type, read as NOT_SET, shown to
monitors (a late one included) with its descriptor, and set by a typed value only.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.values import NOT_SET, Parameter, ParameterType, ParameterValue

from .helpers import DdsSession, wait_until

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def dds(domain_id: int) -> Iterator[DdsSession]:
    with DdsSession(domain_id) as session:
        yield session


def test_an_unset_typed_parameter_travels_and_is_set_by_its_type_only(dds: DdsSession) -> None:
    table = ParameterTable("arm")
    table.declare("gain", None, ParameterDescriptor("", ParameterType.DOUBLE, description="set me"))
    table.declare("ready", True)  # a positive control beside it
    dds.server(table)
    client = dds.client(timeout=5.0)
    client.wait_for_node("arm", timeout=5.0)

    reply = client.get("arm", ["gain", "ready"], with_descriptors=True)
    assert reply.values() == {"gain": NOT_SET, "ready": ParameterValue(ParameterType.BOOL, True)}
    described = {r.name: r.descriptor for r in reply.results}
    assert described["gain"] is not None and described["gain"].type is ParameterType.DOUBLE
    assert described["gain"].description == "set me"

    monitor = dds.monitor()  # joins after the declaration: it learns the state from the topic
    assert monitor.wait_complete(["arm"], timeout=5.0)
    value, descriptor = monitor.snapshot()["arm"].parameters["gain"]
    assert value.type is ParameterType.NOT_SET
    assert descriptor.type is ParameterType.DOUBLE

    refused = client.set("arm", [Parameter("gain", ParameterValue(ParameterType.STRING, "x"))])
    assert not refused.successful and table.describe_one("gain").type is ParameterType.DOUBLE
    assert client.set("arm", [Parameter("gain", ParameterValue(ParameterType.DOUBLE, 2.5))]).successful
    assert wait_until(
        lambda: monitor.snapshot()["arm"].parameters["gain"][0] == ParameterValue(ParameterType.DOUBLE, 2.5),
        timeout=5.0,
    )
