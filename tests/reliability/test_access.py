"""Access: ``--read-only`` servers, read-only parameters, and domain isolation.

Proves: a server started with ``--read-only`` refuses every set, atomic set,
delete and assignment with READ_ONLY and a reason saying so, while get, list and
the event stream keep working; a read-only parameter cannot be changed by any
request path; and two systems on different domain ids never see each other.
Every "nothing happened" is checked after a positive control shows that the same
path, where allowed, does happen (the assignment arrived; a late node is seen).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.values import NOT_SET, Parameter, ParameterValue
from paramdds.dds.assign import Assigner
from paramdds.dds.monitor import EventKind, MonitorEvent
from paramdds.errors import OutcomeUnknownError, UnavailableError

from .conftest import DDS, PARAM_NAMES, Proc, other_domain, start_server, wait

NODE = "robot"


@pytest.mark.timeout(60)
def test_read_only_server_refuses_every_write_and_serves_reads(
    domain_id: int, params_file: Path, dds: DDS, procs: list[Proc]
) -> None:
    server = start_server(domain_id, "-n", NODE, "-p", str(params_file), "--read-only")
    procs.append(server)
    client = dds.client(domain_id, timeout=3.0)
    events: list[MonitorEvent] = []
    monitor = dds.monitor(domain_id, on_event=events.append)
    client.wait_for_node(NODE, timeout=10)
    assert monitor.wait_complete([NODE], timeout=10)
    before = client.get(NODE, sorted(PARAM_NAMES))

    plain = client.set(NODE, {"robot.max_velocity": 2.0, "robot.name": "x"})
    atomic = client.set(NODE, {"robot.max_velocity": 2.0, "robot.enabled": False}, atomic=True)
    cas = client.set(NODE, {"robot.wheel_count": 5}, if_revision=before.revision)
    delete = client.delete(NODE, ["robot.name", "sensor.frame_ids"])
    for reply in (plain, cas, delete):
        assert not any(r.successful for r in reply.results)
        assert all(r.code is not None and r.code.value == "READ_ONLY" for r in reply.results), reply
        assert all("read-only" in r.reason for r in reply.results), reply
    assert not any(r.successful for r in atomic.results)
    assert atomic.results[0].code is not None and atomic.results[0].code.value == "READ_ONLY"
    assert "read-only" in atomic.results[0].reason

    # a retained assignment goes through the same rules: it arrives (the server says it
    # refused it) and changes nothing
    assigner = Assigner(dds.participant(domain_id))
    assigner.assign(NODE, {"robot.max_velocity": 3.0})
    assert wait(lambda: f"assignment for {NODE} partly refused" in server.stderr_text(), 10.0)

    after = client.get(NODE, sorted(PARAM_NAMES))
    assert after.values() == before.values() and after.revision == before.revision
    listed = client.list(NODE)
    assert set(listed.names) == PARAM_NAMES
    assert not [e for e in events if e.event in (EventKind.MODIFIED, EventKind.DELETED)]
    assert {e.name for e in events if e.event is EventKind.ADDED} == PARAM_NAMES


def _guarded_table() -> ParameterTable:
    table = ParameterTable("guarded")
    table.declare("ro", 1, ParameterDescriptor("ro", read_only=True))
    table.declare("ro_dyn", "x", ParameterDescriptor("ro_dyn", read_only=True, dynamic_typing=True))
    table.declare("rw", 1)
    return table


@pytest.mark.timeout(60)
def test_read_only_parameters_cannot_be_changed_by_any_request_path(domain_id: int, dds: DDS) -> None:
    table = _guarded_table()
    dds.server(domain_id, table)
    client = dds.client(domain_id, timeout=3.0)
    client.wait_for_node("guarded", timeout=10)
    revision = table.revision

    attempts = {
        "set": client.set("guarded", {"ro": 2}),
        "set same value": client.set("guarded", {"ro": 1}),
        "set with type change": client.set("guarded", {"ro_dyn": 5}),
        "compare-and-set": client.set("guarded", {"ro": 2}, if_revision=table.revision),
        "delete": client.delete("guarded", ["ro_dyn"]),
        "delete static": client.set("guarded", [Parameter("ro", NOT_SET)]),
    }
    for path, reply in attempts.items():
        assert not reply.results[0].successful, path
        assert reply.results[0].code is not None and reply.results[0].code.value == "READ_ONLY", path
    atomic = client.set("guarded", {"rw": 2, "ro": 2}, atomic=True)
    assert not any(r.successful for r in atomic.results)  # all or nothing: rw is not applied either

    assert table.get("rw") == ParameterValue.from_python(1) and table.revision == revision

    # an assignment carrying a writable parameter too: that one is applied (the positive
    # control: the assignment arrived and was processed), the read-only ones are not
    Assigner(dds.participant(domain_id)).assign("guarded", {"ro": 7, "ro_dyn": "y", "rw": 5})
    assert wait(lambda: table.get("rw") == ParameterValue.from_python(5), 10.0)

    assert table.get("ro") == ParameterValue.from_python(1)
    assert table.get("ro_dyn") == ParameterValue.from_python("x")
    assert table.revision == revision + 1
    # and the table's own API says the same
    with pytest.raises(Exception, match="read-only"):
        table.undeclare("ro_dyn")


@pytest.mark.timeout(60)
def test_two_domains_never_see_each_other(domain_id: int, dds: DDS) -> None:
    domain_a, domain_b = domain_id, other_domain(domain_id)

    def table(node: str, value: int) -> ParameterTable:
        t = ParameterTable(node)
        t.declare("v", value)
        return t

    dds.server(domain_a, table("alpha", 1), table("shared", 1))
    dds.server(domain_b, table("beta", 2), table("shared", 2))
    client_a = dds.client(domain_a, timeout=2.0)
    client_b = dds.client(domain_b, timeout=2.0)
    monitor_a = dds.monitor(domain_a)
    client_a.wait_for_node("alpha", timeout=10)
    client_b.wait_for_node("beta", timeout=10)

    assert client_a.get_value("shared", "v").value == 1
    assert client_b.get_value("shared", "v").value == 2
    with pytest.raises(UnavailableError):
        client_a.get("beta", ["v"])
    # not sent (UNAVAILABLE) once client_b's discovery has settled; sent while it is still
    # going on, and then unanswered: OUTCOME_UNKNOWN (a set, once sent, is never "failed")
    with pytest.raises((UnavailableError, OutcomeUnknownError)):
        client_b.set("alpha", {"v": 9})

    assert monitor_a.wait_synced(timeout=5)
    # nodes that start now in both domains: the one in A shows up in A's monitor (the
    # positive control: late arrivals are seen), the one in B, started first, does not
    dds.server(domain_b, table("late_b", 2))
    dds.server(domain_a, table("late_a", 1))
    assert monitor_a.wait_complete(["late_a"], timeout=10)
    assert client_a.get_value("late_a", "v").value == 1
    states = monitor_a.snapshot()
    assert set(states) == {"alpha", "shared", "late_a"}
    assert states["shared"].parameters["v"][0].value == 1
    assert {n.node for n in client_a.nodes()} == {"alpha", "shared", "late_a"}
