"""``load`` takes back a dump: unchanged values are skipped and reported, a no-op load sends nothing.

Real servers on loopback: the CLI against a ``paramdds server`` (with a read-only
parameter), and a property test in process (a real server and client per test) that for
any node ``dump | load`` changes nothing.
"""

from __future__ import annotations

import json
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter
from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.file_load import load, plan_load
from paramdds.formats.files import dump_text, parse_ros_text

from ..core.test_yaml_dump import _VALUES  # every value type, with the YAML-tricky strings
from ..dds.helpers import DdsSession
from ._support import Proc, next_domain, run_cli, start_server

ROOT = Path(__file__).resolve().parents[2]
SPEC = str(ROOT / "examples" / "robot_spec.yaml")
PARAMS = str(ROOT / "examples" / "params.yaml")


def at(domain: int) -> str:
    (node,) = json.loads(run_cli(domain, "nodes", "-o", "json").stdout)
    return str(node["at"])


@pytest.mark.slow
@pytest.mark.parametrize("atomic", [False, True], ids=["each", "atomic"])
def test_a_dump_loads_back_unchanged_sending_nothing(tmp_path: Path, atomic: bool) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "--spec", SPEC, "-p", PARAMS)
    watch = Proc(domain, ["watch", "robot1", "-o", "json"])
    try:
        watch.wait_for('"synced"')
        for descriptors in (True, False):
            dump = run_cli(domain, "dump", "robot1", *([] if descriptors else ["--no-descriptors"]))
            assert dump.returncode == 0, dump.stderr
            path = tmp_path / "robot1.yaml"
            path.write_text(dump.stdout)
            before = at(domain)
            loaded = run_cli(
                domain, "load", "robot1", str(path), "-o", "json", *(["--atomic"] if atomic else [])
            )
            assert loaded.returncode == 0, loaded.stderr
            results = json.loads(loaded.stdout)
            revision = results.pop("revision")
            assert len(results) == 8 and "robot.wheel_count" in results  # read-only, unchanged
            assert all(r == {"successful": True, "reason": "unchanged"} for r in results.values()), results
            assert before == at(domain) and before.endswith(f":{revision}")
        table = run_cli(domain, "load", "robot1", str(path))
        assert table.returncode == 0 and "robot.wheel_count: unchanged" in table.stdout.splitlines()
        assert watch.drain(0.5) == []  # no event
    finally:
        server.stop()
        watch.stop(signal.SIGINT)


@pytest.mark.slow
def test_load_sends_only_what_changes(tmp_path: Path) -> None:
    domain = next_domain()
    server = start_server(domain, "-n", "robot1", "--spec", SPEC, "-p", PARAMS)
    try:
        dump = run_cli(domain, "dump", "robot1").stdout
        path = tmp_path / "robot1.yaml"
        path.write_text(dump.replace("max_velocity: 1.5", "max_velocity: 2.5"))
        loaded = run_cli(domain, "load", "robot1", str(path), "-o", "json")
        assert loaded.returncode == 0, loaded.stderr
        results = json.loads(loaded.stdout)
        assert results["robot.max_velocity"] == {"successful": True, "reason": ""}
        assert results["robot.wheel_count"]["reason"] == "unchanged"
        assert at(domain).endswith(":2")
        # a changed read-only value is still refused by the node
        path.write_text(dump.replace("wheel_count: 4", "wheel_count: 6"))
        refused = run_cli(domain, "load", "robot1", str(path), "-o", "json")
        assert refused.returncode == 1
        assert json.loads(refused.stdout)["robot.wheel_count"]["successful"] is False
    finally:
        server.stop()


def test_a_plain_ros2_file_loads_with_its_integers_for_doubles(tmp_path: Path) -> None:
    """A hand-written ROS 2 file (``max_velocity: 2`` for a double) compares as the node holds it."""
    plan = plan_load(
        [Parameter("v", PV(T.INTEGER, 2))],
        [_held("v", PV(T.DOUBLE, 2.0))],
    )
    assert plan.unchanged == ("v",) and plan.changed == ()


def _held(name: str, value: PV) -> object:
    from paramdds.core.results import GetResult

    return GetResult(name, value, ParameterDescriptor(name, value.type))


# -- the property: for any node, dump | load is a no-op ------------------------------------------------

_NAMES = st.lists(
    st.sampled_from(["a", "b", "robot", "x_1", "on", "n-2", "s/t"]), min_size=1, max_size=3
).map(".".join)
_TABLES = st.dictionaries(_NAMES, st.tuples(_VALUES, st.booleans(), st.booleans()), max_size=8)


@pytest.fixture(scope="module")
def session() -> Iterator[tuple[DdsSession, object, object]]:
    with DdsSession(next_domain()) as dds:
        yield dds, dds.server(), dds.client()


_count = iter(range(10**6))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(table=_TABLES, descriptors=st.booleans())
def test_dump_then_load_is_a_no_op_for_any_node(
    session: tuple[DdsSession, object, object], table: dict[str, tuple[PV, bool, bool]], descriptors: bool
) -> None:
    from paramdds.dds.client import ParameterClient
    from paramdds.dds.server import ParameterServer

    _, server, client = session
    assert isinstance(server, ParameterServer) and isinstance(client, ParameterClient)
    node = f"n{next(_count)}"
    t = ParameterTable(node)
    # a prefix that is also a name (a and a.b) is fine; skip names the table refuses as a set
    for name, (value, read_only, dynamic) in table.items():
        t.declare(
            name, value, ParameterDescriptor(name, value.type, read_only=read_only, dynamic_typing=dynamic)
        )
    server.add_node(t)
    names = client.list(node).names
    got = client.get(node, list(names), with_descriptors=True)
    snapshot = [
        (r.name, r.value, r.descriptor or ParameterDescriptor(r.name, r.value.type))
        for r in got.results
        if r.value is not None
    ]
    text = dump_text({node: snapshot}, with_descriptors=descriptors)
    params = [Parameter(n, v) for n, v, _ in parse_ros_text(text, "dump", node)]
    for atomic in (False, True):
        reply = load(client, node, params, atomic=atomic)
        assert [r.reason for r in reply.results] == ["unchanged"] * len(table)
        assert reply.revision == got.revision == t.revision
    server.remove_node(node)
