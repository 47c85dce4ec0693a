"""Parameter lists (a `parameters:` list): typed entries, loud failures, order kept."""

from __future__ import annotations

from pathlib import Path

import pytest

from paramdds.core.values import Parameter
from paramdds.core.values import ParameterType as T
from paramdds.core.values import ParameterValue as PV
from paramdds.errors import FileFormatError
from paramdds.formats.paramlist import load_param_list, load_param_list_str

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_example_file_has_its_seven_parameters_in_order() -> None:
    params = load_param_list(EXAMPLES / "params.yaml")
    assert [p.name for p in params] == [
        "robot.max_velocity",
        "robot.max_acceleration",
        "robot.name",
        "robot.enabled",
        "robot.wheel_count",
        "sensor.frequencies",
        "sensor.topics",
    ]
    assert params[0].value == PV(T.DOUBLE, 1.5)
    assert params[3].value == PV(T.BOOL, True)
    assert params[4].value == PV(T.INTEGER, 4)
    assert params[6].value.type is T.STRING_ARRAY


def entry(type_: str, value: str, name: str = "p") -> str:
    return f"parameters:\n  - name: {name}\n    type: {type_}\n    value: {value}\n"


@pytest.mark.parametrize(
    ("type_", "value", "expected"),
    [
        ("double", "2", PV(T.DOUBLE, 2.0)),  # an integer widens, never crashes
        ("double_array", "[1, 2.5]", PV(T.DOUBLE_ARRAY, (1.0, 2.5))),
        ("string", "1.50", PV(T.STRING, "1.50")),  # the type is stated: the text is kept
        ("string", "'on'", PV(T.STRING, "on")),
        ("string_array", "[1, x]", PV(T.STRING_ARRAY, ("1", "x"))),
        ("integer_array", "[]", PV(T.INTEGER_ARRAY, ())),
        ("byte_array", "[0, 255]", PV(T.BYTE_ARRAY, b"\x00\xff")),
        ("bool", "off", PV(T.BOOL, False)),
        ("integer", "0x10", PV(T.INTEGER, 16)),
    ],
)
def test_values_are_read_as_their_stated_type(type_: str, value: str, expected: PV) -> None:
    assert load_param_list_str(entry(type_, value)) == [Parameter("p", expected)]


@pytest.mark.parametrize(
    ("text", "line", "match"),
    [
        (entry("float", "1.0"), 3, r"'p': unknown type 'float'"),
        (entry("integer", "1.5"), 4, r"'p': expected an integer, got double 1.5"),
        (entry("integer", "'5'"), 4, r"'p': expected an integer, got string '5'"),
        (entry("bool", "1"), 4, r"'p': expected a bool"),
        (entry("double_array", "1.0"), 4, r"'p': expected a double_array \(a list\)"),
        (entry("byte_array", "[300]"), 4, r"'p': a byte must be 0..255"),
        (entry("integer", ""), 4, r"'p': no value"),
        ("parameters:\n  - name: p\n    value: 1\n", 2, r"'p': missing key 'type'"),
        ("parameters:\n  - name: p\n    type: integer\n    value: 1\n    unit: m\n", 5, r"'p': unknown key"),
        ("parameters:\n  - type: integer\n    value: 1\n", 2, r"parameter #1: missing key 'name'"),
        (entry("integer", "1") + "  - name: p\n    type: integer\n    value: 2\n", 5, r"'p' is given twice"),
        ("params:\n  - {}\n", 1, r"unknown top-level key 'params'"),
        ("parameters: 5\n", 1, r"must be a list"),
        ("parameters:\n  - name: p\n    type: integer\n    value: [1\n", 5, r"YAML syntax error"),
    ],
)
def test_every_problem_names_file_line_and_parameter(text: str, line: int, match: str) -> None:
    with pytest.raises(FileFormatError, match=match) as info:
        load_param_list_str(text, source="seed.yaml")
    assert (info.value.file, info.value.line) == ("seed.yaml", line)


def test_an_empty_file_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "empty.yaml"
    path.write_text("")
    with pytest.raises(FileFormatError, match="empty"):
        load_param_list(path)
