"""JSON Schema parameter files (paramdds/formats/schema/: load, enforce, declare, check, export).

The Autoware schemas and parameter files are read where CI puts them
(``<repo>/../shared/realworld/autoware``, see its SOURCES.md); the verdicts they are
compared with are check-jsonschema's, read from that SOURCES.md. No DDS here.
"""

from __future__ import annotations

import json
import logging
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterType, ParameterValue
from paramdds.errors import ErrorCode, FileFormatError, ParamddsError
from paramdds.formats.ros import load_ros_params
from paramdds.formats.schema import NodeSchema, declare_schema, load_schema, load_schema_str
from paramdds.formats.schema.check import autoware_pairs, check_with_schema, check_with_spec
from paramdds.formats.schema.export import derive_schema
from paramdds.formats.spec import load_spec_str

_REPO = Path(__file__).resolve().parents[2]
_PLACES = (_REPO.parent / "shared" / "realworld", _REPO.parent.parent / "shared" / "realworld")
REALWORLD = next((p for p in _PLACES if p.is_dir()), _PLACES[0])
AUTOWARE = REALWORLD / "autoware"
needs_realworld = pytest.mark.skipif(not AUTOWARE.is_dir(), reason=f"{AUTOWARE} is absent (CI has it)")
T = ParameterType
_TYPES = {"boolean": T.BOOL, "integer": T.INTEGER, "number": T.DOUBLE, "string": T.STRING}
_ARRAYS = {
    "boolean": T.BOOL_ARRAY,
    "integer": T.INTEGER_ARRAY,
    "number": T.DOUBLE_ARRAY,
    "string": T.STRING_ARRAY,
}


def recorded_verdicts() -> list[tuple[Path, Path, bool]]:
    """(schema, param file, check-jsonschema passes) for every pair SOURCES.md lists."""
    text = (AUTOWARE / "SOURCES.md").read_text()
    out = []
    for section in re.split(r"\n## \d+\. ", text)[1:]:
        schema = re.search(r"\| `([^`]+\.schema\.json)` \|", section)
        assert schema is not None, section[:80]
        for file, verdict in re.findall(r"^- `([^`]+\.param\.yaml)`: \*\*(pass|fail)\*\*", section, re.M):
            out.append((AUTOWARE / schema.group(1), AUTOWARE / file, verdict == "pass"))
    return out


PAIRS = recorded_verdicts() if AUTOWARE.is_dir() else []
PASSING = [(s, p) for s, p, ok in PAIRS if ok]


def _verdict(schema_path: Path, params: Path) -> bool:
    try:
        schema = load_schema(schema_path, declare=False)
        return not check_with_schema(schema, params)
    except FileFormatError:
        return False


@needs_realworld
def test_sources_md_lists_every_pair_with_a_verdict() -> None:
    assert len({s for s, _, _ in PAIRS}) == 16
    assert len(PAIRS) == 19
    assert sum(not ok for _, _, ok in PAIRS) == 2


@needs_realworld
@pytest.mark.parametrize(("schema", "params", "passes"), PAIRS, ids=lambda x: getattr(x, "name", str(x)))
def test_offline_verdict_equals_check_jsonschemas(schema: Path, params: Path, passes: bool) -> None:
    assert _verdict(schema, params) is passes


@needs_realworld
def test_autoware_convention_pairs_the_files_ci_pairs() -> None:
    pairs = {s.name: [p.name for p in ps] for s, ps in autoware_pairs(AUTOWARE)}
    assert len(pairs) == 16
    assert pairs["joy_controller.schema.json"] == [
        f"joy_controller_{x}.param.yaml" for x in ("ds4", "g29", "p65", "xbox")
    ]
    assert pairs["adapi_adaptors.schema.json"] == []  # initial_pose.param.yaml: not by the convention


def _declared(schema_path: Path, params: Path) -> tuple[NodeSchema, ParameterTable]:
    schema = load_schema(schema_path)
    values = load_ros_params(params, "node")
    table = ParameterTable("node", overrides=values)
    declare_schema(table, schema, values)
    return schema, table


def _leaf_schemas(schema_path: Path) -> dict[str, dict[str, object]]:
    """name -> the schema of that property, resolved with jsonschema's own resolver."""
    schema = load_schema(schema_path)
    resolver = schema._validator._resolver
    out: dict[str, dict[str, object]] = {}

    def walk(node: dict[str, object], prefix: str, res: object) -> None:
        while "$ref" in node:
            resolved = res.lookup(node["$ref"])  # type: ignore[attr-defined]
            node, res = resolved.contents, resolved.resolver
        if node.get("type") == "object":
            for key, sub in node.get("properties", {}).items():  # type: ignore[attr-defined]
                try:
                    walk(sub, f"{prefix}.{key}" if prefix else key, res)
                except Exception:
                    continue  # the dangling ref nobody needs
        else:
            out[prefix] = node

    walk(schema.root["properties"]["/**"]["properties"]["ros__parameters"], "", resolver)
    return out


@needs_realworld
@pytest.mark.parametrize(("schema_path", "params"), PASSING, ids=lambda x: x.name)
def test_passing_pair_declares_every_parameter_with_the_schemas_type_and_description(
    schema_path: Path, params: Path
) -> None:
    schema, table = _declared(schema_path, params)
    leaves = _leaf_schemas(schema_path)
    assert set(table.names()) == set(leaves)
    for name, leaf in leaves.items():
        d = table.describe_one(name)
        assert d.description == leaf.get("description", ""), name
        kind = leaf.get("type")
        items = leaf.get("items")
        if kind in _TYPES:
            assert d.type is _TYPES[kind] and not d.dynamic_typing, name
        elif kind == "array" and isinstance(items, dict) and items.get("type") in _TYPES:
            assert d.type is _ARRAYS[str(items["type"])], name
        else:
            assert d.dynamic_typing, name
        if "minimum" in leaf and kind in ("number", "integer"):
            r = d.floating_point_range or d.integer_range
            assert r is not None and r.from_value == leaf["minimum"], name
    # the node's state is valid, and it is what the file says where the file says something
    assert schema.violations({n: v for n, v, _ in table.snapshot()}) == []
    for name, value in load_ros_params(params, "node").items():
        if name not in leaves:
            continue  # a group without additionalProperties: false lets the file have more
        got = table.get(name)
        assert got == value or got == value.coerce(got.type), name


def _table(rel: str, cfg: str) -> tuple[NodeSchema, ParameterTable]:
    schemas = list((AUTOWARE / rel / "schema").glob("*.schema.json"))
    params = AUTOWARE / rel / "config" / cfg
    schema = next(s for s in schemas if cfg.startswith(s.name[: -len(".schema.json")]))
    return _declared(schema, params)


# (package, param file, parameter, a value the schema refuses, what the reason says)
REFUSALS = [
    (
        "autoware_pointcloud_preprocessor",
        "ring_outlier_filter_node.param.yaml",
        "distance_ratio",
        -1.0,
        "within",
    ),
    ("autoware_joy_controller", "joy_controller_ds4.param.yaml", "accel_sensitivity", 1.5, "within"),
    (
        "autoware_joy_controller",
        "joy_controller_ds4.param.yaml",
        "update_rate",
        0.0,
        "less than or equal to the minimum of 0",
    ),
    (
        "autoware_radar_crossing_objects_noise_filter",
        "radar_crossing_objects_noise_filter.param.yaml",
        "angle_threshold",
        1.5708,
        "greater than or equal to the maximum of 1.5708",
    ),
    ("autoware_joy_controller", "joy_controller_ds4.param.yaml", "joy_type", "PS5", "is not one of"),
    (
        "autoware_pointcloud_preprocessor",
        "concatenate_and_time_sync_node.param.yaml",
        "output_frame",
        "",
        "non-empty",
    ),
    (
        "autoware_pointcloud_preprocessor",
        "concatenate_and_time_sync_node.param.yaml",
        "input_topics",
        ["a"],
        "too short",
    ),
    (
        "autoware_pointcloud_preprocessor",
        "concatenate_and_time_sync_node.param.yaml",
        "input_topics",
        ["a", ""],
        "non-empty",
    ),
    (
        "autoware_pointcloud_preprocessor",
        "concatenate_and_time_sync_node.param.yaml",
        "matching_strategy.type",
        "advanced",
        "not valid under any of the given schemas",
    ),  # dependencies > oneOf > const / required
    (
        "autoware_lidar_centerpoint",
        "centerpoint_ml_package.param.yaml",
        "model_params.class_names",
        ["CAR", "CAR"],
        "non-unique",
    ),
]


@needs_realworld
@pytest.mark.parametrize(("rel", "cfg", "name", "bad", "reason"), REFUSALS, ids=lambda x: str(x)[:40])
def test_a_set_breaking_each_keyword_is_refused_with_the_schemas_reason(
    rel: str, cfg: str, name: str, bad: object, reason: str
) -> None:
    schema, table = _table(rel, cfg)
    before = table.revision
    out = table.set([Parameter(name, ParameterValue.from_python(bad))])
    r = out.results[0]
    assert not r.successful and reason in r.reason, r.reason
    assert name.split(".")[-1] in r.reason or "within" in r.reason
    assert table.revision == before
    # and check-jsonschema's verdict on the same values written as a file is the same
    values = {n: v for n, v, _ in table.snapshot()}
    values[name] = ParameterValue.from_python(bad)
    assert schema.violations(values)


@needs_realworld
def test_naive_branch_needs_the_timestamps_absent_so_their_defaults_are_not_applied() -> None:
    _, table = _table("autoware_pointcloud_preprocessor", "concatenate_and_time_sync_node.param.yaml")
    assert table.get("matching_strategy.type").value == "naive"
    assert table.get_many(["matching_strategy.lidar_timestamp_offsets"])[0].value.type is T.NOT_SET


@needs_realworld
def test_required_refuses_a_delete_and_additional_properties_a_new_name() -> None:
    schema = load_schema(AUTOWARE / "autoware_map_loader/schema/pointcloud_map_loader.schema.json")
    values = load_ros_params(AUTOWARE / "autoware_map_loader/config/pointcloud_map_loader.param.yaml", "n")
    table = ParameterTable("n", overrides=values, allow_undeclared=True)
    declare_schema(table, schema, values)
    assert table.describe_one("pcd_paths_or_directory").dynamic_typing  # an array without items
    out = table.set([Parameter("pcd_paths_or_directory", ParameterValue(T.NOT_SET, None))])
    assert not out.results[0].successful
    assert "'pcd_paths_or_directory' is a required property" in out.results[0].reason
    out = table.set([Parameter("pcd_paths_or_directory", ParameterValue(T.STRING, "x"))])
    assert "is not of type 'array'" in out.results[0].reason
    out = table.set([Parameter("extra", ParameterValue(T.INTEGER, 1))])
    assert "Additional properties are not allowed" in out.results[0].reason
    assert not table.has("extra")


@needs_realworld
def test_a_refused_atomic_set_applies_nothing() -> None:
    _, table = _table("autoware_joy_controller", "joy_controller_ds4.param.yaml")
    before = dict((n, v) for n, v, _ in table.snapshot())
    out = table.set_atomically(
        [
            Parameter("accel_ratio", ParameterValue(T.DOUBLE, 2.0)),
            Parameter("joy_type", ParameterValue(T.STRING, "X")),
        ]
    )
    assert [r.successful for r in out.results] == [False, False]
    assert "the atomic set failed on 'joy_type'" in out.results[0].reason
    assert "is not one of" in out.results[1].reason and out.results[1].code is ErrorCode.INVALID_VALUE
    assert dict((n, v) for n, v, _ in table.snapshot()) == before


@needs_realworld
def test_descriptor_says_ranges_and_constraints() -> None:
    _, table = _table("autoware_joy_controller", "joy_controller_ds4.param.yaml")
    d = table.describe_one("update_rate")
    assert d.floating_point_range is not None and d.floating_point_range.from_value == 0.0
    assert "> 0" in d.additional_constraints and "required" in d.additional_constraints
    assert 'one of ["P65", "DS4", "G29", "XBOX"]' in table.describe_one("joy_type").additional_constraints
    assert table.get("update_rate").type is T.DOUBLE  # "default": "10.0" and a file value


@needs_realworld
def test_a_ref_that_fails_is_an_error_only_when_needed(tmp_path: Path) -> None:
    ndt = AUTOWARE / "autoware_ndt_scan_matcher"
    schema = load_schema(ndt / "schema/ndt_scan_matcher.schema.json")
    assert "regularization" in schema.ref_errors and not any(
        e.name == "regularization" for e in schema.entries
    )
    values = load_ros_params(ndt / "config/ndt_scan_matcher.param.yaml", "n")
    values["regularization.enable"] = ParameterValue(T.BOOL, True)
    with pytest.raises(FileFormatError, match=r"ndt_regularization\.json"):
        declare_schema(ParameterTable("n", overrides=values), schema, values)


# --- bad input -----------------------------------------------------------------------------


def _write(tmp_path: Path, text: str, name: str = "x.schema.json") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _envelope(params: dict[str, object], **extra: object) -> str:
    return json.dumps(
        {
            "type": "object",
            "properties": {"/**": {"type": "object", "properties": {"ros__parameters": params}}},
            **extra,
        }
    )


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("{", "not JSON"),
        ("[1]", "holds a JSON object"),
        ('{"type": "object", "minimum": "5"}', "not a valid draft-07 schema"),
        (
            _envelope({"type": "object", "properties": {"a": {"type": "number", "minimun": 0}}}),
            r"#/properties/~1\*\*/properties/ros__parameters/properties/a/minimun: unknown keyword 'minimun'",
        ),
        (_envelope({"$ref": "#/definitions/nothing"}), "cannot be resolved"),
        (_envelope({"$ref": "other.json#/x"}), "other.json"),
        (
            _envelope(
                {"$ref": "#/definitions/a"},
                definitions={"a": {"$ref": "#/definitions/b"}, "b": {"$ref": "#/definitions/a"}},
            ),
            "cycle",
        ),
        ('{"type": "object"}', "no node key"),
        (
            _envelope({"type": "object", "properties": {"a": {"type": "string", "format": "ros-topic"}}}),
            "format 'ros-topic' cannot be enforced",
        ),
    ],
)
def test_bad_schemas_are_clear_errors_naming_file_and_json_path(
    tmp_path: Path, text: str, match: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(FileFormatError, match=match) as info:
        load_schema(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    "root",
    [
        {"$ref": "#"},
        {
            "definitions": {"a": {"$ref": "#/definitions/b"}, "b": {"$ref": "#/definitions/a"}},
            "$ref": "#/definitions/a",
        },
    ],
)
def test_a_ref_cycle_met_while_checking_a_file_is_an_error_in_bounded_time(
    tmp_path: Path, root: object
) -> None:
    # check-jsonschema itself dies of a RecursionError on these
    schema = load_schema(_write(tmp_path, json.dumps(root)), declare=False)
    params = _write(tmp_path, "/**:\n  ros__parameters:\n    a: 1\n", "p.param.yaml")
    start = time.monotonic()
    with pytest.raises(FileFormatError, match=r"recurses without end \(a \$ref cycle\)"):
        check_with_schema(schema, params)
    assert time.monotonic() - start < 5.0


def test_unknown_keyword_only_warns_with_lenient(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = _write(
        tmp_path,
        _envelope({"type": "object", "properties": {"a": {"type": "number", "dependentRequired": {}}}}),
    )
    schema = load_schema(path, lenient=True)
    assert [e.name for e in schema.entries] == ["a"]
    assert "dependentRequired" in caplog.text


def test_pathological_schemas_end_in_bounded_time(tmp_path: Path) -> None:
    # a huge enum (about 1 MB), a deep nesting, a self-referencing group, a ref fan-out
    big = _envelope(
        {"type": "object", "properties": {"a": {"type": "string", "enum": [f"v{i}" for i in range(120_000)]}}}
    )
    assert len(big) > 1_000_000
    deep: dict[str, object] = {"type": "number"}
    for _ in range(200):
        deep = {"type": "object", "properties": {"x": deep}}
    fan = {
        f"d{i}": {
            "type": "object",
            "properties": {f"p{j}": {"$ref": f"#/definitions/d{i + 1}"} for j in range(10)},
        }
        for i in range(8)
    }
    fan["d8"] = {"type": "number"}
    cases = [
        (big, None),
        (_envelope(deep), "nested"),
        (
            _envelope(
                {"$ref": "#/definitions/g"},
                definitions={"g": {"type": "object", "properties": {"a": {"$ref": "#/definitions/g"}}}},
            ),
            "cycle|contains itself",
        ),
        (_envelope({"$ref": "#/definitions/d0"}, definitions=fan), "more than"),
    ]
    for text, match in cases:
        start = time.monotonic()
        if match is None:
            schema = load_schema(_write(tmp_path, text))
            assert schema.violations({"a": ParameterValue(T.STRING, "nope")})
            assert len(schema.entries[0].descriptor.additional_constraints) < 2100
        else:
            with pytest.raises(FileFormatError, match=match):
                load_schema(_write(tmp_path, text))
        assert time.monotonic() - start < 5.0


def test_a_file_value_the_schema_refuses_stops_the_node_or_is_left_out_with_lenient() -> None:
    text = _envelope(
        {"type": "object", "properties": {"rate": {"type": "number", "default": 1.0, "exclusiveMinimum": 0}}}
    )
    schema = load_schema_str(text, source="s.json")
    bad = {"rate": ParameterValue(T.DOUBLE, 0.0)}
    with pytest.raises(FileFormatError, match=r"rate: 0\.0 is less than or equal to the minimum of 0"):
        declare_schema(ParameterTable("n", overrides=bad), schema, bad)
    table = ParameterTable("n", overrides=bad)
    notes = declare_schema(table, schema, bad, lenient=True)
    assert table.get("rate").value == 1.0 and "'rate' starts without the file's value" in notes[0]


# --- properties ---------------------------------------------------------------------------------

_NUMBER = {"type": "number", "default": 0.5, "exclusiveMinimum": 0.0, "maximum": 10.0, "multipleOf": 0.25}
_NUM_SCHEMA = load_schema_str(
    _envelope(
        {
            "type": "object",
            "properties": {
                "x": _NUMBER,
                "n": {"type": "integer", "default": 2, "minimum": 1, "enum": [1, 2, 3, 50]},
            },
        }
    )
)


@settings(max_examples=200, deadline=None)
@given(
    x=st.floats(allow_nan=False, allow_infinity=False, min_value=-20, max_value=20)
    | st.sampled_from([0.0, 0.25, 10.0, 10.25]),
    n=st.integers(min_value=-5, max_value=60),
)
def test_the_tables_verdict_is_jsonschemas_on_the_same_document(x: float, n: int) -> None:
    table = ParameterTable("n")
    declare_schema(table, _NUM_SCHEMA)
    out = table.set_atomically(
        [Parameter("x", ParameterValue(T.DOUBLE, x)), Parameter("n", ParameterValue(T.INTEGER, n))]
    )
    document = {"/**": {"ros__parameters": {"x": x, "n": n}}}
    reference = jsonschema.Draft7Validator(json.loads(_NUM_SCHEMA_TEXT)).is_valid(document)
    assert out.results[0].successful is reference


_NUM_SCHEMA_TEXT = _envelope(
    {
        "type": "object",
        "properties": {
            "x": _NUMBER,
            "n": {"type": "integer", "default": 2, "minimum": 1, "enum": [1, 2, 3, 50]},
        },
    }
)


# --- specs -----------------------------------------------------------------------------------

SPEC = """\
robot:
  speed: {type: double, default_value: 1.0, validation: {bounds<>: [0.0, 5.0]}}
  mode: {type: string, default_value: auto, validation: {one_of<>: [[auto, manual]]}}
  name: {type: string, validation: {size_lt<>: [8], not_empty<>: []}}
  joints: {type: string_array, default_value: [a], validation: {unique<>: null, subset_of<>: [[a, b, c]]}}
  gains: {type: double_array, default_value: [1.0], validation: {element_bounds<>: [0.0, 2.0]}}
  count: {type: int, default_value: 1, validation: {gt<>: [0]}}
"""


def test_check_a_file_against_a_spec(tmp_path: Path) -> None:
    spec = load_spec_str(SPEC)
    good = _write(tmp_path, "n:\n  ros__parameters:\n    name: abc\n", "good.yaml")
    assert check_with_spec(spec, good) == []
    bad = _write(
        tmp_path,
        "n:\n  ros__parameters:\n    speed: 7.0\n    mode: x\n    nope: 1\n    count: 0\n",
        "bad.yaml",
    )
    found = {(f.path, f.section) for f in check_with_spec(spec, bad)}
    assert found == {("speed", "n"), ("mode", "n"), ("nope", "n"), ("count", "n"), ("name", "")}


def test_a_specs_schema_says_its_validators() -> None:
    spec = load_spec_str(SPEC)
    schema = derive_schema(
        [(e.name, e.default, e.descriptor) for e in spec],
        title="robot",
        required=[e.name for e in spec if e.required],
    )
    props = schema["definitions"]["robot"]["properties"]
    assert props["speed"] == {"type": "number", "minimum": 0.0, "maximum": 5.0, "default": 1.0}
    assert props["mode"]["enum"] == ["auto", "manual"]
    assert (props["name"]["minLength"], props["name"]["maxLength"]) == (1, 7)
    assert props["joints"]["uniqueItems"] is True and props["joints"]["items"]["enum"] == ["a", "b", "c"]
    assert props["gains"]["items"] == {"type": "number", "minimum": 0.0, "maximum": 2.0}
    assert props["count"]["exclusiveMinimum"] == 0
    assert schema["definitions"]["robot"]["required"] == ["name"]
    jsonschema.Draft7Validator.check_schema(schema)


# --- the incremental check is the whole check ---------------------------------------------------

_STRINGS = st.sampled_from(["", "x", "naive", "advanced", "twist", "odom", "CAR", "map", "DS4", "P65"])
_BY_TYPE = {
    T.BOOL: st.booleans(),
    T.INTEGER: st.integers(min_value=-3, max_value=50),
    T.DOUBLE: st.floats(min_value=-2.0, max_value=50.0, allow_nan=False),
    T.STRING: _STRINGS,
    T.STRING_ARRAY: st.lists(_STRINGS, max_size=3).map(tuple),
    T.DOUBLE_ARRAY: st.lists(st.floats(min_value=-1.0, max_value=1.0), max_size=3).map(tuple),
    T.INTEGER_ARRAY: st.lists(st.integers(min_value=-1, max_value=3), max_size=3).map(tuple),
}
_DIFFERENTIAL = [
    ("autoware_pointcloud_preprocessor", "concatenate_and_time_sync_node.param.yaml"),
    ("autoware_multi_object_tracker", "input_channels.param.yaml"),
    ("autoware_lidar_centerpoint", "centerpoint_ml_package.param.yaml"),
    ("autoware_map_loader", "pointcloud_map_loader.param.yaml"),
]


def _whole_check(schema: NodeSchema) -> object:
    def check(values: dict[str, ParameterValue], before: dict[str, object]) -> tuple[str, str] | None:
        found = schema.violations(values)
        return None if not found else ("", str(found[0]))

    return check


@needs_realworld
@pytest.mark.parametrize(("rel", "cfg"), _DIFFERENTIAL, ids=lambda x: x)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_incremental_checks_give_the_whole_checks_verdict(rel: str, cfg: str, data: st.DataObject) -> None:
    schema, fast = _table(rel, cfg)
    _, whole = _table(rel, cfg)
    whole.set_node_validator(_whole_check(schema))  # type: ignore[arg-type]
    entries = {e.name: e for e in schema.entries}
    for _ in range(data.draw(st.integers(min_value=1, max_value=8))):
        names = data.draw(st.lists(st.sampled_from(sorted(entries)), min_size=1, max_size=3, unique=True))
        params = []
        for name in names:
            d = entries[name].descriptor
            kind = d.type if not d.dynamic_typing else data.draw(st.sampled_from([T.STRING_ARRAY, T.DOUBLE]))
            if data.draw(st.integers(0, 9)) == 0:
                value = ParameterValue(T.NOT_SET, None)  # a delete (refused on static types by both)
            else:
                value = ParameterValue(kind, data.draw(_BY_TYPE[kind]))
            params.append(Parameter(name, value))
        atomic = data.draw(st.booleans())
        a = fast.set_atomically(params) if atomic else fast.set(params)
        b = whole.set_atomically(params) if atomic else whole.set(params)
        assert [r.successful for r in a.results] == [r.successful for r in b.results], (params, a, b)
        assert fast.snapshot() == whole.snapshot()
        assert schema.violations({n: v for n, v, _ in fast.snapshot()}) == []


# --- a default no reader can take as its type ------------------------------------------------

_COMMA = _envelope(
    {
        "type": "object",
        "properties": {
            "gain": {"type": "number", "default": "0,262"},
            "rate": {"type": "number", "default": 2.0, "minimum": 0.0},
        },
    }
)


def test_a_default_not_of_its_type_is_a_warning_and_the_file_value_is_used(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = _write(tmp_path, _COMMA)
    with caplog.at_level(logging.WARNING, logger="paramdds.formats.schema.describe"):
        schema = load_schema(path)
        load_schema(path)  # loaded again (a second node): warned once
    (warning,) = [r.getMessage() for r in caplog.records]
    assert str(path) in warning and "properties/gain/default" in warning and '"0,262"' in warning
    given = {"gain": ParameterValue(T.DOUBLE, 0.5)}
    table = ParameterTable("n", overrides=given)
    declare_schema(table, schema, given)
    assert table.get("gain").value == 0.5 and table.get("rate").value == 2.0
    bare = ParameterTable("n")
    declare_schema(bare, schema, {})
    assert bare.has("gain") and bare.describe_one("gain").type is T.DOUBLE
    with pytest.raises(ParamddsError, match="no value yet"):  # declared without one, as with no default
        bare.get("gain")
    assert table.set([Parameter("rate", ParameterValue(T.DOUBLE, -1.0))]).results[0].successful is False


def test_a_required_parameter_whose_default_is_unreadable_and_no_file_gives_fails_naming_it(
    tmp_path: Path,
) -> None:
    gain = {"type": "number", "default": "0,262"}
    params = {"type": "object", "required": ["gain"], "properties": {"gain": gain}}
    schema = load_schema(_write(tmp_path, _envelope(params)))
    with pytest.raises(FileFormatError, match="'gain' is a required property"):
        declare_schema(ParameterTable("n"), schema, {})


@needs_realworld
def test_a_real_schema_with_a_decimal_comma_default_loads_and_check_agrees_with_check_jsonschema(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The real obstacle_stop_planner pair, its ``lowpass_gain`` default written "0,262"."""
    real = AUTOWARE / "autoware_obstacle_stop_planner"
    text = (real / "schema" / "obstacle_stop_planner.schema.json").read_text()
    assert text.count('"default": "0.9"') == 1
    schema_path = _write(tmp_path, text.replace('"default": "0.9"', '"default": "0,262"'), "osp.schema.json")
    params = tmp_path / "osp.param.yaml"
    shutil.copy(real / "config" / "obstacle_stop_planner.param.yaml", params)
    checker = Path(sys.executable).with_name("check-jsonschema")
    theirs = subprocess.run(
        [str(checker), "--schemafile", str(schema_path), str(params)], capture_output=True, text=True
    )
    assert theirs.returncode == 0, theirs.stdout  # check-jsonschema never judges a default
    assert _verdict(schema_path, params) is True
    with caplog.at_level(logging.WARNING, logger="paramdds.formats.schema.describe"):
        schema, table = _declared(schema_path, params)
    assert any("lowpass_gain/default" in r.getMessage() and "0,262" in r.getMessage() for r in caplog.records)
    assert table.get("lowpass_gain").value == 0.9  # the file's value
    assert table.get("chattering_threshold").value == 0.5
    assert schema.violations({"lowpass_gain": ParameterValue(T.STRING, "x")})  # the schema still enforces
