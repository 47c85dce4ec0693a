"""States the conformance work added (issue 14), on real Cyclone DDS.

* rclcpp and rclpy let a node declare a parameter with a type and no value: the wire
  carries it described with its type, read as NOT_SET, shown to monitors (a late one
  included) with its descriptor, and set by a typed value only.
* Mapped spec parameters: when the key array changes, the parameters of the new entry
  are declared right after the set and reach clients and monitors.
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


def test_mapped_parameters_of_a_new_key_entry_reach_clients_and_monitors(dds: DdsSession) -> None:
    from paramdds.formats.spec import declare_spec, load_spec_str

    spec = load_spec_str(
        "arm:\n  joints:\n    type: string_array\n    default_value: [j1]\n"
        "  gains:\n    __map_joints:\n      p:\n        type: double\n        default_value: 1.0\n"
    )
    table = ParameterTable("arm")
    declare_spec(table, spec)
    dds.server(table)
    client = dds.client(timeout=5.0)
    client.wait_for_node("arm", timeout=5.0)
    monitor = dds.monitor()
    assert monitor.wait_complete(["arm"], timeout=5.0)
    assert set(monitor.snapshot()["arm"].parameters) == {"joints", "gains.j1.p"}

    reply = client.set("arm", [Parameter("joints", ParameterValue(ParameterType.STRING_ARRAY, ("j1", "j2")))])
    assert reply.successful
    assert client.list("arm").names == ("gains.j1.p", "gains.j2.p", "joints")
    assert client.get("arm", ["gains.j2.p"]).values() == {
        "gains.j2.p": ParameterValue(ParameterType.DOUBLE, 1.0)
    }
    assert wait_until(lambda: "gains.j2.p" in monitor.snapshot()["arm"].parameters, timeout=5.0)
    assert monitor.snapshot()["arm"].revision == table.revision
