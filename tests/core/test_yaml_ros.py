"""ROS 2 parameter files: sections, wildcards, precedence, flattening, errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor, Validator
from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.errors import ErrorCode, FileFormatError
from paramdds.formats.ros import (
    load_ros_file_full,
    load_ros_params,
    load_ros_params_str,
    load_ros_text_full,
    node_key_matches,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(
    ("key", "node_id", "matches"),
    [
        ("/**", "robot1", True),
        ("/**", "ns/deep/robot1", True),
        ("/*", "robot1", True),
        ("/*", "ns/robot1", False),
        ("robot1", "robot1", True),
        ("/robot1", "robot1", True),
        ("/robot1", "ns/robot1", False),
        ("robot1", "robot10", False),
        ("/ns/robot1", "ns/robot1", True),
        ("ns/robot1", "ns/robot1", True),
        ("/ns/*", "ns/robot1", True),
        ("/ns/*", "ns/a/robot1", False),
        ("/ns/*", "other/robot1", False),
        ("/**/robot1", "a/b/robot1", True),
        ("/**/robot1", "robot1", True),
        ("/**/robot1", "robot2", False),
        ("/ns/**", "ns/a/b", True),
    ],
)
def test_node_keys_match_like_rclcpp(key: str, node_id: str, matches: bool) -> None:
    assert node_key_matches(key, node_id) is matches


FILE = """\
/**:
  ros__parameters:
    shared: 1
    speed: 1.0
robot1:
  ros__parameters:
    speed: 2.0
    only1: true
robot2:
  ros__parameters:
    speed: 3.0
    only2: true
"""


def test_only_the_matching_sections_are_applied() -> None:
    r1 = load_ros_params_str(FILE, "robot1")
    assert r1 == {"shared": PV(T.INTEGER, 1), "speed": PV(T.DOUBLE, 2.0), "only1": PV(T.BOOL, True)}
    assert "only2" not in r1
    other = load_ros_params_str(FILE, "robot3")
    assert other == {"shared": PV(T.INTEGER, 1), "speed": PV(T.DOUBLE, 1.0)}


def test_later_matching_sections_win_in_file_order() -> None:
    text = """\
robot1:
  ros__parameters:
    speed: 2.0
/**:
  ros__parameters:
    speed: 1.0
"""
    assert load_ros_params_str(text, "robot1")["speed"] == PV(T.DOUBLE, 1.0)


def test_nested_node_keys_and_nested_params_flatten() -> None:
    text = """\
ns:
  robot1:
    ros__parameters:
      robot:
        arm:
          joints: [j1, j2]
        "x.y": 3
"""
    assert load_ros_params_str(text, "ns/robot1") == {
        "robot.arm.joints": PV(T.STRING_ARRAY, ("j1", "j2")),
        "robot.x.y": PV(T.INTEGER, 3),
    }
    assert load_ros_params_str(text, "robot1") == {}


def test_the_same_node_written_twice_is_one_section_later_values_winning() -> None:
    text = """\
/ns/robot1:
  ros__parameters:
    a: 1
    b: 1
ns:
  robot1:
    ros__parameters:
      b: 2
"""
    assert load_ros_params_str(text, "ns/robot1") == {"a": PV(T.INTEGER, 1), "b": PV(T.INTEGER, 2)}


def test_pyyaml_differences_follow_rcl() -> None:
    text = "n:\n  ros__parameters:\n    e: 1e3\n    t: 1:20\n    h: 0x1A\n    o: on\n    q: 'on'\n"
    assert load_ros_params_str(text, "n") == {
        "e": PV(T.DOUBLE, 1000.0),
        "t": PV(T.STRING, "1:20"),
        "h": PV(T.INTEGER, 26),
        "o": PV(T.BOOL, True),
        "q": PV(T.STRING, "on"),
    }


def test_typed_tags_give_byte_arrays_and_typed_empty_lists() -> None:
    text = "n:\n  ros__parameters:\n    b: !byte_array [1, 2]\n    e: !string_array []\n"
    assert load_ros_params_str(text, "n") == {
        "b": PV(T.BYTE_ARRAY, b"\x01\x02"),
        "e": PV(T.STRING_ARRAY, ()),
    }


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        ("n:\n  ros__parameters:\n    a: [1, 2.5]\n", 3, r"'a'.*one type.*1\.0, not 1"),
        ("n:\n  ros__parameters:\n    a: []\n", 3, r"'a'.*empty list"),
        ("n:\n  ros__parameters:\n    a:\n", 3, r"'a'.*no value"),
        ("n:\n  ros__parameters:\n    a: 1\n    a: 2\n", 4, r"'a' is repeated"),
        ("n:\n  ros__parameters:\n    a.b: 1\n    a:\n      b: 2\n", 5, r"'a.b' is given twice"),
        ("n:\n  ros__parameters:\n    a: [[1]]\n", 3, r"'a'.*only single values"),
        ("n:\n  ros__parameters:\n    a: {}\n    b: 1\n", 3, r"'a'.*empty map"),
        ("n:\n  ros__parameters:\n", 2, r"'n'.*ros__parameters is empty"),
        ("n:\n  ros__parameters:\n    a: [1\n", 4, r"YAML syntax error"),
        ("ros__parameters:\n  a: 1\n", 1, r"needs a node name"),
        ("n:\n  x: 1\n", 2, r"node 'n/x'.*expected a map"),
        ("1robot:\n  ros__parameters:\n    a: 1\n", 2, r"not a valid name"),
        ("/a//b:\n  ros__parameters:\n    a: 1\n", 2, r"empty part"),
        ("n:\n  ros__parameters:\n    <<: {a: 1}\n", 3, r"merge keys"),
    ],
)
def test_errors_name_file_line_and_parameter(text: str, line: int, match: str) -> None:
    with pytest.raises(FileFormatError, match=match) as info:
        load_ros_params_str(text, "n", source="bad.yaml")
    assert info.value.code is ErrorCode.FILE_FORMAT
    assert info.value.file == "bad.yaml"
    assert info.value.line == line
    assert str(info.value).startswith(f"bad.yaml:{line}: ")


def test_an_error_in_a_section_for_another_node_still_fails_the_whole_file() -> None:
    text = "robot1:\n  ros__parameters:\n    a: 1\nrobot2:\n  ros__parameters:\n    b: [1, 2.0]\n"
    with pytest.raises(FileFormatError, match="'b'"):
        load_ros_params_str(text, "robot1")


def test_unreadable_and_non_utf8_files(tmp_path: Path) -> None:
    missing = tmp_path / "missing.yaml"
    with pytest.raises(FileFormatError, match="cannot read") as info:
        load_ros_params(missing, "n")
    assert info.value.file == str(missing)
    latin = tmp_path / "latin.yaml"
    latin.write_bytes(b"n:\n  ros__parameters:\n    a: caf\xe9\n")
    with pytest.raises(FileFormatError, match="not UTF-8") as info:
        load_ros_params(latin, "n")
    assert info.value.line == 3


def test_descriptor_section_is_read_back() -> None:
    text = """\
n:
  ros__parameters:
    speed: 2
    empty: []
  paramdds__descriptors:
    speed:
      type: double
      description: "Top speed"
      read_only: true
      floating_point_range: [0.0, 5, 0.0]
      validators:
        - bounds: [0.0, 5.0]
        - unique: []
    empty:
      type: integer_array
"""
    loaded = load_ros_text_full(text, "n")
    assert loaded == [
        ("empty", PV(T.INTEGER_ARRAY, ()), ParameterDescriptor("empty", T.INTEGER_ARRAY)),
        (
            "speed",
            PV(T.DOUBLE, 2.0),  # an integer widens to the descriptor's double
            ParameterDescriptor(
                "speed",
                T.DOUBLE,
                description="Top speed",
                read_only=True,
                floating_point_range=FloatingPointRange(0.0, 5.0, 0.0),
                validators=(Validator("bounds", (PV(T.DOUBLE, 0.0), PV(T.DOUBLE, 5.0))), Validator("unique")),
            ),
        ),
    ]


@pytest.mark.parametrize(
    ("descriptor", "match"),
    [
        ("      type: double\n      colour: red\n", "unknown descriptor field 'colour'"),
        ("      description: x\n", "needs a type"),
        ("      type: float\n", "unknown type 'float'"),
        ("      type: string\n", r"expects a string but got integer"),
        (
            "      type: integer\n      validators:\n        - between: [1, 2]\n",
            "unknown validator 'between'",
        ),
        ("      type: integer\n      validators:\n        - gt: [1, 2]\n", "takes 1 argument"),
    ],
)
def test_bad_descriptors_are_refused(descriptor: str, match: str) -> None:
    text = f"n:\n  ros__parameters:\n    a: 1\n  paramdds__descriptors:\n    a:\n{descriptor}"
    with pytest.raises(FileFormatError, match=match):
        load_ros_text_full(text, "n")


def test_a_descriptor_without_a_value_is_refused() -> None:
    text = "n:\n  ros__parameters:\n    a: 1\n  paramdds__descriptors:\n    b:\n      type: integer\n"
    with pytest.raises(FileFormatError, match="'b': a descriptor without a value") as info:
        load_ros_text_full(text, "n")
    assert info.value.line == 5


def test_example_file_loads_per_node() -> None:
    path = EXAMPLES / "robot_params.yaml"
    robot1 = load_ros_params(path, "robot1")
    assert robot1["robot.max_velocity"] == PV(T.DOUBLE, 1.5)
    assert robot1["robot.serial"] == PV(T.STRING, "0042")
    assert robot1["use_sim_time"] == PV(T.BOOL, False)
    assert load_ros_params(path, "fleet/r2")["robot.max_velocity"] == PV(T.DOUBLE, 0.5)
    assert load_ros_params(path, "other") == {
        "use_sim_time": PV(T.BOOL, False),
        "robot.max_velocity": PV(T.DOUBLE, 1.0),
    }
    assert all(d is None for _, _, d in load_ros_file_full(path, "robot1"))


def test_tags_other_than_ours_are_ignored_as_rcl_ignores_them() -> None:
    # issue 20, kind 6: rcl 10.1 types a tagged value by its content (only !!str and quotes make
    # a string); before, the file was refused
    text = "n:\n  ros__parameters:\n    a: !!float 1\n    b: !custom [1, 2]\n    c: !!str 1\n    d: !x '7'\n"
    got = {k: (v.type.label, v.value) for k, v in load_ros_params_str(text, "n").items()}
    assert got == {
        "a": ("integer", 1),
        "b": ("integer_array", (1, 2)),
        "c": ("string", "1"),
        "d": ("string", "7"),
    }


def test_a_repeated_node_key_merges_as_rcl_does() -> None:
    # issue 20, kind 9 (measured against rcl 10.1): a key of ros__parameters written again keeps
    # the earlier value unless the types agree or the new type is read first (bool, integer,
    # double, string, then arrays); written again inside a map, the later value wins.
    text = (
        "n:\n  ros__parameters:\n    a: 1\n    b: x\n    c.d: 1\n    e: 1\n    f: [1]\n"
        "n:\n  ros__parameters:\n    a: 2.5\n    b: 7\n    c:\n      d: 2.5\n    e: 2\n    f: []\n"
    )
    got = {k: (v.type.label, v.value) for k, v in load_ros_params_str(text, "n").items()}
    assert got == {
        "a": ("integer", 1),
        "b": ("integer", 7),
        "c.d": ("double", 2.5),
        "e": ("integer", 2),
        "f": ("integer_array", (1,)),
    }
