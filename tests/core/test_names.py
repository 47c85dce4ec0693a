"""Parameter names and node ids (paramdds.core.names)."""

import pytest

from paramdds.core.limits import MAX_NAME_BYTES, MAX_NODE_ID_BYTES
from paramdds.core.names import (
    NodeFilter,
    canonical_node_glob,
    canonical_node_id,
    is_node_glob,
    is_valid_name,
    validate_name,
)
from paramdds.errors import ErrorCode, InvalidNameError


@pytest.mark.parametrize(
    "name",
    [
        "a",
        "robot.max_velocity",
        "qos_overrides./parameter_events.publisher.depth",
        "joints.0.name",
        "with-dash_and_underscore",
        "x" * MAX_NAME_BYTES,
    ],
)
def test_valid_names_are_returned_unchanged(name: str) -> None:
    assert validate_name(name) == name
    assert is_valid_name(name)


@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("", "empty"),
        (".a", "empty segment"),
        ("a.", "empty segment"),
        ("a..b", "empty segment"),
        ("a b", "' '"),
        ("a.b$", "'$'"),
        ("vélocité", "'é'"),
        ("x" * (MAX_NAME_BYTES + 1), "256 bytes"),
        (5, "must be a string"),
        (None, "must be a string"),
    ],
)
def test_invalid_names_say_which_rule_they_broke(name: object, words: str) -> None:
    with pytest.raises(InvalidNameError) as info:
        validate_name(name)
    assert words in info.value.message
    assert info.value.code is ErrorCode.INVALID_NAME
    assert not is_valid_name(name)


@pytest.mark.parametrize(
    ("raw", "canonical"),
    [
        ("robot1", "robot1"),
        ("/robot1", "robot1"),
        ("/ns/robot1", "ns/robot1"),
        ("ns/sub/robot_1", "ns/sub/robot_1"),
        ("n" * MAX_NODE_ID_BYTES, "n" * MAX_NODE_ID_BYTES),
    ],
)
def test_node_ids_have_one_canonical_form_without_leading_slash(raw: str, canonical: str) -> None:
    assert canonical_node_id(raw) == canonical


@pytest.mark.parametrize(
    ("raw", "words"),
    [
        ("", "empty"),
        ("/", "empty"),
        ("//robot", "empty segment"),
        ("ns//robot", "empty segment"),
        ("robot/", "empty segment"),
        ("robot-1", "'-'"),
        ("robot.1", "'.'"),
        ("robot 1", "' '"),
        ("n" * (MAX_NODE_ID_BYTES + 1), "256 bytes"),
        (7, "must be a string"),
    ],
)
def test_invalid_node_ids_are_refused_clearly(raw: object, words: str) -> None:
    with pytest.raises(InvalidNameError) as info:
        canonical_node_id(raw)
    assert words in info.value.message


def test_node_globs_match_ids_and_are_checked_as_node_ids() -> None:
    only = NodeFilter(["/robot1", "fleet/*", "s?/arm[12]"])
    assert only.patterns() == ["robot1", "fleet/*", "s?/arm[12]"]
    for node in ("robot1", "fleet/a", "fleet/ns/b", "s1/arm2"):
        assert node in only, node
    for node in ("robot2", "fleet", "s1/arm3", "s10/arm1", None):
        assert node not in only, node
    assert canonical_node_glob("/fleet/*") == "fleet/*" and not is_node_glob("fleet/a")
    for bad in ("fleet/-*", "fleet//*", "*/"):
        with pytest.raises(InvalidNameError, match="invalid node glob"):
            NodeFilter([bad])
