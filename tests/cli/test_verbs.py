"""The request verbs against real servers: output shapes and every exit-code cell.

One module-wide domain with three servers started in parallel:

* ``robot1`` and ``robot2`` (one process): the seed's seven parameters plus a ROS 2
  file with descriptors (a range, a read-only, a dynamic, a byte array, an empty
  array);
* ``frozen`` (``--read-only``);
* ``strict`` (``--strict-types --allow-undeclared``).

Tests that change values use names no other test reads.
"""

from __future__ import annotations

import json
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from paramdds.dds import filters

from ._support import SEED_PARAMS, Proc, next_domain, run_cli

ROS_PARAMS = """\
/**:
  ros__parameters:
    limits:
      speed: 1.0
      fixed: 7
      ratio: 0.5
    blob: !byte_array [1, 2]
    weights: !double_array [0.5]
    dyn: 3
    scratch:
      a: 1.0
      b: 1.0
      c: 1.0
      d: 1.0
    special: 1.0
  paramdds__descriptors:
    limits.speed:
      type: double
      description: top speed
      floating_point_range: [0.0, 5.0, 0.0]
    limits.fixed:
      type: integer
      read_only: true
    dyn:
      type: integer
      dynamic_typing: true
"""


class Cluster:
    def __init__(self, tmp: Path) -> None:
        self.domain = next_domain()
        self.seed = tmp / "params.yaml"
        self.seed.write_text(SEED_PARAMS)
        self.ros = tmp / "ros.yaml"
        self.ros.write_text(ROS_PARAMS)
        files = ["-p", str(self.seed), "-p", str(self.ros)]
        self.procs = [
            Proc(self.domain, ["server", "-n", "robot1", "-n", "robot2", *files]),
            Proc(self.domain, ["server", "-n", "frozen", "--read-only", *files]),
            Proc(self.domain, ["server", "-n", "strict", "--strict-types", "--allow-undeclared", *files]),
        ]
        self.procs[0].wait_for("Serving node robot1")
        self.procs[0].wait_for("Serving node robot2")
        for proc in self.procs[1:]:
            proc.wait_for("Serving node")

    def cli(self, *args: str, timeout: float = 30.0) -> subprocess.CompletedProcess[str]:
        return run_cli(self.domain, *args, timeout=timeout)

    def json(self, *args: str) -> object:
        out = self.cli(*args, "-o", "json")
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout)

    def close(self) -> None:
        for proc in self.procs:
            proc.stop()


@pytest.fixture(scope="module")
def c(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    cluster = Cluster(tmp_path_factory.mktemp("verbs"))
    yield cluster
    cluster.close()


def one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line]
    assert lines and all(line.startswith("paramdds: error: ") for line in lines), err
    assert "Traceback" not in err
    return lines[0]


# -- exit 0 and the JSON shapes --------------------------------------------------------------------


@pytest.mark.slow
def test_get_json_maps_each_name_to_its_value(c: Cluster) -> None:
    assert c.json(
        "get",
        "robot1",
        "robot.max_velocity",
        "robot.wheel_count",
        "robot.name",
        "robot.enabled",
        "sensor.frame_ids",
        "blob",
    ) == {
        "robot.max_velocity": 1.5,
        "robot.wheel_count": 4,
        "robot.name": "my_robot",
        "robot.enabled": True,
        "sensor.frame_ids": ["base", "laser"],
        "blob": [1, 2],
    }


@pytest.mark.slow
def test_get_table_prints_type_and_value(c: Cluster) -> None:
    out = c.cli("get", "robot1", "robot.max_velocity")
    assert (out.returncode, out.stdout) == (0, "robot.max_velocity = double 1.5\n")


@pytest.mark.slow
def test_list_json_is_an_array_of_names(c: Cluster) -> None:
    names = c.json("list", "robot1")
    assert isinstance(names, list) and "robot.max_velocity" in names and "limits.speed" in names
    assert c.json("list", "robot1", "--prefix", "robot") == [
        "robot.enabled",
        "robot.max_acceleration",
        "robot.max_velocity",
        "robot.name",
        "robot.wheel_count",
    ]


def test_describe_json_shape(c: Cluster) -> None:
    got = c.json("describe", "robot1", "limits.speed")
    assert isinstance(got, dict)
    last = got["limits.speed"].pop("last_change")  # the value the node started with, from its files
    assert set(last) == {"who", "verified", "via", "time", "revision"} and last["who"]
    assert (last["verified"], last["via"], last["revision"]) == (True, "start", 1)
    assert got == {
        "limits.speed": {
            "type": "double",
            "description": "top speed",
            "read_only": False,
            "dynamic_typing": False,
            "integer_range": None,
            "floating_point_range": {"from_value": 0.0, "to_value": 5.0, "step": 0.0},
            "additional_constraints": "",
            "validators": [],
        }
    }


def test_set_json_shape_and_a_double_prints_with_a_point(c: Cluster) -> None:
    out = c.json("set", "robot2", "limits.speed=2")  # an integer widens for a double parameter
    assert isinstance(out, dict) and out["limits.speed"] == {"successful": True, "reason": ""}
    assert isinstance(out["revision"], int) and out["revision"] > 0
    got = c.cli("get", "robot2", "limits.speed", "-o", "json")
    assert got.stdout.strip() == '{\n  "limits.speed": 2.0\n}'


def test_non_finite_doubles_print_as_strings(c: Cluster) -> None:
    assert c.cli("set", "robot2", "scratch.a=.nan", "scratch.b=inf", "scratch.c=-.inf").returncode == 0
    assert c.json("get", "robot2", "scratch.a", "scratch.b", "scratch.c") == {
        "scratch.a": "nan",
        "scratch.b": "inf",
        "scratch.c": "-inf",
    }


def test_byte_arrays_and_empty_lists_take_the_nodes_type(c: Cluster) -> None:
    assert c.cli("set", "robot2", "blob=[7, 255]", "weights=[]").returncode == 0
    assert c.json("get", "robot2", "blob", "weights") == {"blob": [7, 255], "weights": []}


@pytest.mark.slow
def test_set_if_revision_compares_the_incarnation_too(c: Cluster) -> None:
    (row,) = [r for r in c.json("nodes") if r["node"] == "robot2"]
    at = str(row["at"])
    incarnation, _, revision = at.partition(":")
    other = f"{int(incarnation, 16) ^ 1:016x}:{revision}"  # the same revision, another start
    stale = c.cli("set", "robot2", "limits.speed=2.5", "--if-revision", other)
    assert stale.returncode == 1 and "incarnation" in stale.stdout + stale.stderr
    done = c.cli("set", "robot2", "limits.speed=2.5", "--if-revision", at, "-o", "json")
    assert done.returncode == 0, done.stdout + done.stderr
    assert json.loads(done.stdout)["revision"] == int(revision) + 1
    bad = c.cli("set", "robot2", "limits.speed=2.5", "--if-revision", "zz:3")
    assert bad.returncode == 2 and "--if-revision" in bad.stderr


def test_nodes_json_lists_every_live_node(c: Cluster) -> None:
    rows = c.json("nodes")
    assert isinstance(rows, list)
    by_name = {r["node"]: r for r in rows}
    assert set(by_name) == {"robot1", "robot2", "frozen", "strict"}
    assert set(by_name["robot1"]) == {
        "node",
        "online",
        "parameters",
        "host",
        "pid",
        "revision",
        "also_hosted_by",
        "request_filter",
        "incarnation",
        "at",
        "origin",
        "status",
    }
    assert by_name["robot1"]["also_hosted_by"] == []
    assert by_name["robot1"]["origin"] is None  # served here, not mirrored
    assert by_name["robot1"]["status"] is None
    incarnation = str(by_name["robot1"]["incarnation"])
    assert len(incarnation) == 16 and int(incarnation, 16) != 0
    assert by_name["robot1"]["at"] == f"{incarnation}:{by_name['robot1']['revision']}"
    assert by_name["robot2"]["incarnation"] != incarnation  # drawn per node
    assert by_name["robot1"]["request_filter"] == ("native" if filters.NATIVE else "handler")
    assert by_name["robot1"]["online"] is True and by_name["robot1"]["parameters"] == 18
    assert by_name["robot1"]["pid"] == by_name["robot2"]["pid"] == c.procs[0].popen.pid


@pytest.mark.slow
def test_nodes_and_dump_take_several_nodes_and_globs(c: Cluster) -> None:
    assert [r["node"] for r in c.json("nodes", "robot?", "frozen")] == ["frozen", "robot1", "robot2"]
    dump = c.cli("dump", "robot*", "strict")
    assert dump.returncode == 0, dump.stderr
    sections = [line[:-1] for line in dump.stdout.splitlines() if line and not line[0].isspace()]
    assert sections == ["strict", "robot1", "robot2"]  # the exact names, then each glob's nodes
    none = c.cli("dump", "nobody*")
    assert none.returncode == 3 and "no online node matches nobody*" in none.stderr, none
    bad = c.cli("nodes", "robot-*")
    assert bad.returncode == 2 and "invalid node glob" in bad.stderr, bad


@pytest.mark.slow
def test_dump_then_load_round_trips(c: Cluster, tmp_path: Path) -> None:
    dump = c.cli("dump", "robot1")
    assert dump.returncode == 0, dump.stderr
    # a ROS 2 parameter file by default (rcl refuses a paramdds__descriptors map), with them on request
    assert dump.stdout.startswith("robot1:\n  ros__parameters:\n")
    assert "paramdds__descriptors" not in dump.stdout
    described = c.cli("dump", "robot1", "--descriptors")
    assert described.stdout.startswith(dump.stdout) and "paramdds__descriptors" in described.stdout
    assert c.cli("dump", "robot1", "--no-descriptors").stdout == dump.stdout  # still accepted
    path = tmp_path / "dump.yaml"
    text = dump.stdout.replace("robot1:", "robot2:", 1).replace("max_velocity: 1.5", "max_velocity: 2.5")
    path.write_text(text)
    loaded = c.cli("load", "robot2", str(path), "-o", "json")
    assert loaded.returncode == 0, loaded.stderr  # the read-only limits.fixed is unchanged: skipped
    results = json.loads(loaded.stdout)
    assert results["robot.max_velocity"] == {"successful": True, "reason": ""}
    assert results["limits.fixed"] == {"successful": True, "reason": "unchanged"}
    assert c.json("get", "robot2", "robot.max_velocity") == {"robot.max_velocity": 2.5}


@pytest.mark.slow
def test_delete_a_dynamic_parameter(c: Cluster) -> None:
    assert c.cli("delete", "robot2", "dyn").returncode == 0
    assert c.cli("get", "robot2", "dyn").returncode == 1


# -- exit 1: the node refused or lacked something -----------------------------------------------------


def test_unknown_names_are_left_out_and_reported(c: Cluster) -> None:
    out = c.cli("get", "robot1", "robot.name", "no.such", "-o", "json")
    assert out.returncode == 1
    assert json.loads(out.stdout) == {"robot.name": "my_robot"}
    assert "no.such" in one_error_line(out.stderr)


@pytest.mark.parametrize(
    ("args", "reason"),
    [
        (["limits.speed=9.0"], "5.0"),  # validation
        (["limits.fixed=8"], "read"),  # read-only
        (["robot.name=5"], "string"),  # type
        (["nope=1"], "nope"),  # unknown parameter
    ],
)
def test_refusals_exit_1(c: Cluster, args: list[str], reason: str) -> None:
    out = c.cli("set", "robot1", *args, "-o", "json")
    assert out.returncode == 1
    (result,) = [v for k, v in json.loads(out.stdout).items() if k != "revision"]
    assert result["successful"] is False and reason in result["reason"].lower()
    one_error_line(out.stderr)


def test_partial_non_atomic_set_keeps_the_good_ones(c: Cluster) -> None:
    out = c.cli("set", "robot2", "scratch.d=4.0", "limits.fixed=1", "-o", "json")
    assert out.returncode == 1
    res = json.loads(out.stdout)
    assert res["scratch.d"]["successful"] and not res["limits.fixed"]["successful"]
    assert c.json("get", "robot2", "scratch.d") == {"scratch.d": 4.0}


@pytest.mark.slow
def test_atomic_set_applies_nothing_on_failure(c: Cluster) -> None:
    out = c.cli("set", "robot2", "--atomic", "limits.ratio=0.9", "limits.fixed=1")
    assert out.returncode == 1
    assert c.json("get", "robot2", "limits.ratio") == {"limits.ratio": 0.5}


@pytest.mark.slow
def test_compare_and_set_conflict(c: Cluster) -> None:
    revision = c.json("set", "robot2", "special=1.5")["revision"]  # type: ignore[index]
    assert c.cli("set", "robot2", "special=2.5", "--if-revision", str(revision)).returncode == 0
    stale = c.cli("set", "robot2", "special=3.5", "--if-revision", str(revision), "-o", "json")
    assert stale.returncode == 1
    assert json.loads(stale.stdout)["special"]["successful"] is False
    assert c.json("get", "robot2", "special") == {"special": 2.5}


@pytest.mark.slow
def test_read_only_server_refuses_sets_and_deletes(c: Cluster) -> None:
    assert c.cli("set", "frozen", "robot.max_velocity=2.0").returncode == 1
    assert c.cli("delete", "frozen", "dyn").returncode == 1
    assert c.json("get", "frozen", "robot.max_velocity") == {"robot.max_velocity": 1.5}


def test_strict_types_refuse_an_integer_for_a_double(c: Cluster) -> None:
    out = c.cli("set", "strict", "robot.max_velocity=50")
    assert out.returncode == 1 and "50.0" in out.stdout + out.stderr
    assert c.cli("set", "strict", "robot.max_velocity=50.0").returncode == 0


def test_delete_a_static_parameter_is_refused(c: Cluster) -> None:
    assert c.cli("delete", "robot1", "robot.name").returncode == 1


# -- exit 2: usage and bad local input ---------------------------------------------------------------


@pytest.mark.parametrize(
    "args",
    [
        ["set", "robot1", "robot.name"],  # no '='
        ["set", "robot1", "robot.name=[1, 2"],  # unparsable
        ["set", "robot1", "a=[1, 2.5]"],  # mixed list
        ["get", "robot1"],  # missing NAME
        ["list", "robot1", "--bogus"],  # unknown flag
        ["get", "bad node!", "x"],  # invalid node name
    ],
)
def test_usage_errors_exit_2(c: Cluster, args: list[str]) -> None:
    out = c.cli(*args)
    assert out.returncode == 2
    one_error_line(out.stderr)


def test_bad_yaml_names_file_and_line(c: Cluster, tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("robot1:\n  ros__parameters:\n    a: [1, 2\n    b: 2\n")
    out = c.cli("load", "robot1", str(bad))
    assert out.returncode == 2
    assert f"{bad}:" in one_error_line(out.stderr)
    missing = c.cli("load", "robot1", str(tmp_path / "missing.yaml"))
    assert missing.returncode == 2 and "missing.yaml" in missing.stderr


# -- exit 3: absent node, timeout -------------------------------------------------------------------


def test_absent_node_exits_3_naming_it(c: Cluster) -> None:
    out = c.cli("get", "ghost", "x", "--timeout", "2")
    assert out.returncode == 3
    assert "ghost" in one_error_line(out.stderr)


@pytest.mark.slow
def test_no_answer_within_the_timeout_exits_3(c: Cluster) -> None:
    frozen = c.procs[1].popen
    frozen.send_signal(signal.SIGSTOP)
    try:
        out = c.cli("get", "frozen", "robot.name", "--timeout", "0.5")
    finally:
        frozen.send_signal(signal.SIGCONT)
    assert out.returncode == 3
    assert "frozen" in one_error_line(out.stderr)
