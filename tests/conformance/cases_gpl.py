# ruff: noqa: E501  (data tables: one case per entry reads better than wrapped)
"""Cases from generate_parameter_library (spec parsing, mapped parameters, descriptors) and the
validators now in PickNikRobotics/RSL (our own specs and values).

Spec text is the body under the root namespace key.
"""

from __future__ import annotations

from .runner import ERROR, Case, Typed

GPL = "PickNikRobotics/generate_parameter_library"
PARSE_ERR = f"{GPL} generate_parameter_library_py/generate_parameter_library_py/test/YAML_parse_error_test.py"
MAPPED = f"{GPL} generate_parameter_library_py/generate_parameter_library_py/test/mapped_parameter_test.py"
NESTED_MAP = f"{GPL} generate_parameter_library_py/generate_parameter_library_py/test/test_nested_map.py"
DESC = f"{GPL} example/test/descriptor_test_gtest.cpp"
PARSE = (f"{GPL} generate_parameter_library_py: validate_parameter_definitions (the semantic checks kept "
         "out of the JSON schema)")
CONTROL = ("ros-controls/ros2_controllers diff_drive_controller custom_validators.hpp, since moved to control_toolbox's "
           "control_filters: gt_eq_or_nan / lt_eq_or_nan check gt_eq / lt_eq only when the value is not NaN")
RSL = "PickNikRobotics/RSL tests/parameter_validators.cpp"
VCFG = f"{GPL} generate_parameter_library_py/generate_parameter_library_py/test/test_validate_config.py"

# A spec of the shape test_validate_config.py checks configurations against (our own names).
_NODE_SPEC = (
    "freq:\n  type: double\n  default_value: 5.0\n  validation:\n    gt<>: [0.0]\n"
    "label:\n  type: string\n  default_value: arm\n"
    "required_gain:\n  type: double\n"
    "speed:\n  type: string\n  default_value: fast\n  validation:\n    one_of<>: [[fast, slow]]\n"
    "links:\n  type: string_array\n  default_value: [l1, l2]\n"
    "trims:\n  type: double_array_fixed_2\n  default_value: [0.0, 0.0]\n"
    "cpp_checked:\n  type: int\n  default_value: 4\n  validation:\n    acme_pkg::is_four<>: [4]\n"
    "colour:\n  g:\n    type: int\n    default_value: 0\n    validation:\n      bounds<>: [0, 255]\n"
)
_MAPPED_SPEC = (
    "joints:\n  type: string_array\n  default_value: [hip, knee]\n"
    "pid:\n  __map_joints:\n    p:\n      type: double\n      default_value: 1.0\n"
    "      validation:\n        gt<>: [0.0]\n"
)


def _cfg(body: str, node: str = "n") -> tuple[str, str]:
    return f"{node}:\n  ros__parameters:\n" + "".join(f"    {line}\n" for line in body.splitlines()), node


CONFIGS: list[Case] = [
    Case("gpl-cfg-valid", f"{VCFG}: test_valid_config_reports_nothing", "spec", _NODE_SPEC,
         {"config": _cfg("freq: 25.0\nrequired_gain: 2.5\nspeed: slow\ncolour:\n  g: 100"),
          "values": {"freq": ("double", 25.0), "colour.g": ("integer", 100)}}),
    Case("gpl-cfg-missing-mandatory", f"{VCFG}: test_missing_mandatory_parameter_is_an_error", "spec", _NODE_SPEC,
         {"config": _cfg("freq: 25.0"), "declare_error": "INVALID_VALUE"}),
    Case("gpl-cfg-integer-for-double", f"{VCFG}: test_integer_for_a_double_is_reported", "spec", _NODE_SPEC,
         {"config": _cfg("freq: 25\nrequired_gain: 2.5"), "declare_error": "TYPE_MISMATCH"},
         deliberate="an integer for a double parameter is widened (`50` → `50.0`, rclcpp#979) unless strict",
         ours={"config": _cfg("freq: 25\nrequired_gain: 2.5"), "values": {"freq": ("double", 25.0)}}),
    Case("gpl-cfg-wrong-scalar-type", f"{VCFG}: test_wrong_scalar_type_is_reported", "spec", _NODE_SPEC,
         {"config": _cfg("freq: quick\nrequired_gain: 2.5"), "declare_error": "TYPE_MISMATCH"}),
    Case("gpl-cfg-out-of-bounds", f"{VCFG}: test_value_out_of_bounds_is_reported", "spec", _NODE_SPEC,
         {"config": _cfg("required_gain: 2.5\ncolour:\n  g: 400"), "declare_error": "OUT_OF_RANGE"}),
    Case("gpl-cfg-outside-one-of", f"{VCFG}: test_value_outside_one_of_is_reported", "spec", _NODE_SPEC,
         {"config": _cfg("required_gain: 2.5\nspeed: medium"), "declare_error": "INVALID_VALUE"}),
    Case("gpl-cfg-array-element-type", f"{VCFG}: test_array_element_type_is_checked", "spec", _NODE_SPEC,
         {"config": _cfg("required_gain: 2.5\nlinks: [l1, 3]"), "declare_error": "FILE_FORMAT"}),
    Case("gpl-cfg-fixed-size", f"{VCFG}: test_fixed_size_array_is_checked", "spec", _NODE_SPEC,
         {"config": _cfg("required_gain: 2.5\ntrims: [0.0, 1.0, 2.0]"), "declare_error": "INVALID_VALUE"}),
    Case("gpl-cfg-custom-validator-skipped", f"{VCFG}: test_custom_cpp_validator_is_skipped_with_a_warning", "spec",
         _NODE_SPEC, {"config": _cfg("required_gain: 2.5\ncpp_checked: 9"), "values": {"cpp_checked": ("integer", 9)}}),
    Case("gpl-cfg-wildcard-supplies", f"{VCFG}: test_wildcard_node_supplies_values", "spec", _NODE_SPEC,
         {"config": ("/**:\n  ros__parameters:\n    required_gain: 2.5\nn:\n  ros__parameters:\n    freq: 4.0\n", "n"),
          "values": {"required_gain": ("double", 2.5), "freq": ("double", 4.0)}}),
    Case("gpl-cfg-wildcard-only", f"{VCFG}: test_wildcard_only_config_is_validated", "spec", _NODE_SPEC,
         {"config": ("/**:\n  ros__parameters:\n    freq: -2.0\n    required_gain: 2.5\n", "n"),
          "declare_error": "OUT_OF_RANGE"}),
    Case("gpl-cfg-namespaced-section", f"{VCFG}: test_node_name_with_namespace_or_leading_slash_matches", "spec",
         _NODE_SPEC, {"config": ("grp:\n  n:\n    ros__parameters:\n      freq: -2.0\n      required_gain: 2.5\n",
                                 "grp/n"), "declare_error": "OUT_OF_RANGE"}),
    Case("gpl-cfg-mapped-expand", f"{VCFG}: test_mapped_parameters_expand_from_the_config", "spec", _MAPPED_SPEC,
         {"config": _cfg("joints: [hip, ankle]\npid:\n  hip:\n    p: 3.0\n  ankle:\n    p: -1.0"),
          "declare_error": "OUT_OF_RANGE"}),
    Case("gpl-cfg-mapped-expand-ok", f"{VCFG}: test_mapped_parameters_expand_from_the_config (valid values)", "spec",
         _MAPPED_SPEC, {"config": _cfg("joints: [hip, ankle]\npid:\n  ankle:\n    p: 4.0"),
                        "names": ["joints", "pid.hip.p", "pid.ankle.p"], "values": {"pid.ankle.p": ("double", 4.0)}}),
    Case("gpl-cfg-mapped-default-keys", f"{VCFG}: test_mapped_keys_fall_back_to_the_declared_default", "spec",
         _MAPPED_SPEC, {"config": _cfg("pid:\n  hip:\n    p: -2.0\n  knee:\n    p: 3.0"), "declare_error": "OUT_OF_RANGE"}),
    Case("gpl-cfg-none-type", f"{VCFG}: test_none_typed_parameters_are_left_alone", "spec",
         "plain:\n  type: string\n  default_value: hi\nexternal:\n  type: none\n",
         {"config": _cfg("plain: hi\nexternal:\n  filt:\n    kind: LowPass"), "names": ["plain", "external"]}),
    Case("gpl-cfg-scientific", f"{VCFG}: test_scientific_notation_is_a_double", "spec", _NODE_SPEC,
         {"config": _cfg("freq: 2e4\nrequired_gain: 3e-3"), "values": {"freq": ("double", 20000.0)}}),
    Case("gpl-cfg-empty-array", f"{VCFG}: test_empty_array_is_reported (ROS 2 leaves [] unset)", "spec", _NODE_SPEC,
         {"config": _cfg("required_gain: 2.5\nlinks: []"), "declare_error": "FILE_FORMAT"}),
]


def _yaml(v: object) -> str:
    if isinstance(v, Typed):
        return _yaml(v.value)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_yaml(x) for x in v) + "]"
    return repr(v)


def _e(label: str) -> Typed:
    return Typed(label, [])


# (validator, parameter type, arguments, default, values RSL accepts, values it refuses): the
# relationships each TEST_CASE checks, with our own values.
_ROWS: list[tuple[str, str, str, object, list[object], list[object]]] = [
    ("unique", "string_array", "null", ["", "a", "b"], [["", "a", "b"], _e("string_array")], [["x", "x"]]),
    ("unique", "double_array", "null", [0.5, 1.5, 0.25], [_e("double_array")], [[0.25, 0.25]]),
    ("unique", "int_array", "null", [4, 5, 6], [_e("integer_array")], [[-3, -3]]),
    ("unique", "bool_array", "null", [True, False], [_e("bool_array")], [[True, True]]),
    ("subset_of", "string_array", '[["", "a", "b", "four"]]', ["", "a"], [_e("string_array")], [["zz", "zz"]]),
    ("subset_of", "double_array", "[[0.5, 1.5]]", [0.5, 1.5], [_e("double_array")], [[0.75, 0.75]]),
    ("subset_of", "int_array", "[[4, 5, 6]]", [4, 5, 6], [_e("integer_array")], [[-2, -2]]),
    ("subset_of", "bool_array", "[[true]]", [True], [[True, True]], [[False, False]]),
    ("fixed_size", "string", "[4]", "abcd", [], ["abc", "abcde"]),
    ("fixed_size", "string", "[0]", "", [], ["x"]),
    ("fixed_size", "string_array", "[3]", ["", "a", "b"], [], [["x", "x"]]),
    ("fixed_size", "double_array", "[0]", _e("double_array"), [], [[0.5, 0.5]]),
    ("fixed_size", "int_array", "[3]", [4, 5, 6], [], [[-1, -1]]),
    ("fixed_size", "bool_array", "[2]", [True, False], [], [[True]]),
    ("size_gt", "string", "[2]", "xyz", [], ["xy"]),
    ("size_gt", "string", "[0]", "x", [], [""]),
    ("size_gt", "int_array", "[0]", [-1, -1], [], [_e("integer_array")]),
    ("size_gt", "double_array", "[2]", [1.0, 2.0, 3.0], [], [[1.0, 1.0]]),
    ("size_lt", "string", "[3]", "ab", [], ["abc"]),
    ("size_lt", "string_array", "[3]", ["a", "a"], [], [["", "1", "2"]]),
    ("size_lt", "bool_array", "[3]", [True, False], [], [[True, True, True]]),
    ("not_empty", "string", "null", "x", [], [""]),
    ("not_empty", "string_array", "[]", ["", "1"], [], [_e("string_array")]),
    ("not_empty", "double_array", "null", [1.0], [], [_e("double_array")]),
    ("not_empty", "int_array", "[]", [1, 2], [], [_e("integer_array")]),
    ("not_empty", "bool_array", "null", [False], [], [_e("bool_array")]),
    ("element_bounds", "double_array", "[0.0, 3.0]", [1.0, 2.5, 1.5], [_e("double_array")], [[3.5]]),
    ("element_bounds", "int_array", "[-5, 0]", [-1, 0], [_e("integer_array")], [[1, 2, 3]]),
    ("lower_element_bounds", "double_array", "[0.0]", [1.0, 2.5], [_e("double_array")], [[-0.5]]),
    ("lower_element_bounds", "int_array", "[3]", [3, 4], [], [[1, 2, 3]]),
    ("upper_element_bounds", "double_array", "[0.0]", [-1.0], [_e("double_array")], [[1.0, 2.5, 1.5]]),
    ("upper_element_bounds", "int_array", "[3]", [1, 2, 3], [_e("integer_array")], [[4]]),
    ("bounds", "double", "[1.0, 5.0]", 1.0, [4.5, 5.0], [-4.5, 10.5]),
    ("bounds", "int", "[1, 5]", 1, [4, 5], [-4, 10]),
    ("lt", "double", "[2.0]", -4.5, [], [2.0, 4.5]),
    ("lt", "int", "[1]", -4, [], [1, 4]),
    ("gt", "double", "[2.0]", 4.5, [], [2.0, -4.5]),
    ("gt", "int", "[1]", 4, [], [1, -4]),
    ("lt_eq", "double", "[2.0]", 2.0, [-4.5], [4.5]),
    ("lt_eq", "int", "[1]", 1, [-4], [4]),
    ("gt_eq", "double", "[2.0]", 2.0, [4.5], [-4.5]),
    ("gt_eq", "int", "[1]", 1, [4], [-4]),
    ("one_of", "double", "[[2.0]]", 2.0, [], [0.0]),
    ("one_of", "double", "[[1.0, 2.0, 3.5]]", 2.0, [3.5], [0.0]),
    ("one_of", "int", "[[1, 2, 3, 4]]", 1, [4], [0]),
    ("one_of", "bool", "[[false, true]]", True, [False], []),
    ("one_of", "bool", "[[false]]", False, [], [True]),
    ("one_of", "string", '[["foo", "baz"]]', "foo", ["baz"], [""]),
]


def _validator_cases() -> list[Case]:
    out = []
    for n, (kind, ptype, args, default, accept, refuse) in enumerate(_ROWS):
        text = f"p:\n  type: {ptype}\n  default_value: {_yaml(default)}\n  validation:\n    {kind}<>: {args}\n"
        src = f"{RSL}: TEST_CASE rsl::{kind}"
        out.append(Case(f"rsl-{n:02d}-{kind}-{ptype}-default", src, "spec", text, {"accept": [("p", default)]}))
        out += [Case(f"rsl-{n:02d}-{kind}-{ptype}-accept-{i}", src, "spec", text, {"accept": [("p", v)]})
                for i, v in enumerate(accept)]
        out += [Case(f"rsl-{n:02d}-{kind}-{ptype}-refuse-{i}", src, "spec", text, {"refuse": [("p", v)]})
                for i, v in enumerate(refuse)]
    return out


VALIDATORS: list[Case] = _validator_cases()

SPECS: list[Case] = [
    Case("gpl-valid-file", f"{PARSE_ERR}: test_parse_valid_parameter_file", "spec",
         "speed:\n  type: double\n  default_value: 1.0\nname:\n  type: string\n  default_value: arm\n",
         {"names": ["speed", "name"], "values": {"speed": ("double", 1.0), "name": ("string", "arm")}}),
    Case("gpl-none-type", f"{PARSE_ERR}: test_parse_valid_parameter_file_including_none_type", "spec",
         "anything:\n  type: none\n  default_value: 3\n", {"names": ["anything"], "accept": [("anything", "s")]}),
    Case("gpl-wrong-default-type", f"{PARSE_ERR}: test_expected[wrong_default_type.yaml]", "spec",
         "count:\n  type: int\n  default_value: word\n", ERROR),
    Case("gpl-missing-type", f"{PARSE_ERR}: test_expected[missing_type.yaml]", "spec",
         "count:\n  default_value: 1\n", ERROR),
    Case("gpl-invalid-syntax", f"{PARSE_ERR}: test_expected[invalid_syntax.yaml]", "spec",
         "count:\n  type: int\n  default_value: [1\n", ERROR),
    Case("gpl-invalid-type", f"{PARSE_ERR}: test_expected[invalid_parameter_type.yaml]", "spec",
         "count:\n  type: integer\n  default_value: 1\n", ERROR),
    Case("gpl-bare-fixed-size", f"{PARSE}: arguments that are not a list are wrapped (_as_list)", "spec",
         "xyz:\n  type: double_array\n  default_value: [0.0, 0.0, 0.0]\n  validation:\n    fixed_size<>: 3\n",
         {"accept": [("xyz", [1.0, 2.0, 3.0])], "refuse": [("xyz", [1.0])]}),
    Case("gpl-bare-lower-element-bounds", f"{PARSE}: arguments that are not a list are wrapped (_as_list)",
         "spec", "v:\n  type: double_array\n  default_value: [0.0]\n  validation:\n"
         "    lower_element_bounds<>: -10.0\n", {"accept": [("v", [-10.0])], "refuse": [("v", [-10.5])]}),
    Case("gpl-bare-gt-eq", f"{PARSE}: arguments that are not a list are wrapped (_as_list)", "spec",
         "t:\n  type: double\n  default_value: 0.0\n  validation:\n    gt_eq<>: 0.0\n",
         {"accept": [("t", 0.0)], "refuse": [("t", -0.1)]}),
    Case("gpl-no-angle-brackets", f"{PARSE}: validator names with or without <> (removesuffix)", "spec",
         "t:\n  type: double\n  default_value: 1.0\n  validation:\n    gt_eq: [0.0]\n",
         {"refuse": [("t", -1.0)]}),
    Case("gpl-bounds-with-gt", f"{PARSE}: _check_validator_combinations (bounds excludes gt)", "spec",
         "t:\n  type: int\n  default_value: 1\n  validation:\n    bounds<>: [0, 5]\n    gt<>: [0]\n", ERROR),
    Case("gpl-bounds-with-lt-eq", f"{PARSE}: _check_validator_combinations (bounds excludes lt_eq)", "spec",
         "t:\n  type: int\n  default_value: 1\n  validation:\n    bounds<>: [0, 5]\n    lt_eq<>: [4]\n", ERROR),
    Case("gpl-element-bounds-with-lower", f"{PARSE}: _check_validator_combinations (element_bounds excludes lower_element_bounds)",
         "spec", "t:\n  type: int_array\n  default_value: [1]\n  validation:\n    element_bounds<>: [0, 5]\n"
         "    lower_element_bounds<>: [1]\n", ERROR),
    Case("gpl-gt-with-lt-ok", f"{PARSE}: _check_validator_combinations (gt with lt is allowed)", "spec",
         "t:\n  type: int\n  default_value: 1\n  validation:\n    gt<>: [0]\n    lt<>: [5]\n",
         {"accept": [("t", 4)], "refuse": [("t", 5), ("t", 0)], "ranges": {"t": (0, 5)}}),
    Case("gpl-bounds-lower-above-upper", f"{PARSE}: _check_validator (a range's lower bound above its upper bound)", "spec",
         "t:\n  type: int\n  default_value: 1\n  validation:\n    bounds<>: [5, 0]\n", ERROR),
    Case("gpl-validator-on-wrong-type", f"{PARSE}: _check_validator (a validator that does not apply to the type)", "spec",
         "t:\n  type: string\n  default_value: a\n  validation:\n    gt<>: [0]\n", ERROR),
    Case("gpl-required", f"{VCFG}: test_missing_mandatory_parameter_is_an_error (given by the file, it declares)", "spec",
         "port:\n  type: int\n", {"overrides": {"port": 80}, "values": {"port": ("integer", 80)}}),
    Case("gpl-fixed-string", f"{PARSE}: _check_default_value (a fixed size bounds the length)", "spec",
         "code:\n  type: string_fixed_3\n  default_value: ab\n", {"accept": [("code", "abc")],
                                                                  "refuse": [("code", "abcd")]}),
    Case("gpl-fixed-array", f"{VCFG}: test_fixed_size_array_is_checked", "spec",
         "xs:\n  type: int_array_fixed_2\n  default_value: [1]\n", {"accept": [("xs", [1, 2])],
                                                                    "refuse": [("xs", [1, 2, 3])]}),
    Case("gpl-read-only", "PickNikRobotics/generate_parameter_library README.md: read_only (the parameter cannot change after start)", "spec",
         "ro:\n  type: int\n  default_value: 1\n  read_only: true\n", {"refuse": [("ro", 2)]}),
    Case("gpl-descriptor-bounds-range", f"{DESC}: DescriptorTest.check_integer_descriptors (bounds<> on an int)",
         "spec", "port:\n  type: int\n  default_value: 2000\n  validation:\n    bounds<>: [1500, 9000]\n",
         {"ranges": {"port": (1500, 9000)}}),
    Case("gpl-descriptor-bounds-fp-range", f"{DESC}: DescriptorTest.check_integer_descriptors (the same on a double)",
         "spec", "d:\n  type: double\n  default_value: 1.0\n  validation:\n    bounds<>: [0.0, 2.5]\n",
         {"ranges": {"d": (0.0, 2.5)}}),
    Case("gpl-descriptor-element-bounds-range", f"{DESC}: DescriptorTest.check_floating_point_descriptors "
         "(element_bounds<> on a double array)", "spec",
         "ratios:\n  type: double_array\n  default_value: [0.5]\n  validation:\n    element_bounds<>: [0.2, 20.0]\n",
         {"ranges": {"ratios": (0.2, 20.0)}}),
    Case("gpl-descriptor-lower-bounds", f"{DESC}: DescriptorTest.check_lower_upper_bounds", "spec",
         "kp:\n  type: double\n  default_value: 1.0\n  validation:\n    lower_bounds<>: [0.0002]\n",
         {"ranges": {"kp": (0.0002, 1.7976931348623157e308)}}),
    Case("gpl-descriptor-lt-eq-range", f"{DESC}: DescriptorTest.check_lt_eq (the open end is std::numeric_limits<int64_t>::lowest())",
         "spec", "i:\n  type: int\n  default_value: 0\n  validation:\n    lt_eq<>: [25]\n",
         {"ranges": {"i": (-(2**63), 25)}}),
    Case("gpl-descriptor-gt-range", f"{DESC}: DescriptorTest.check_gt (from_value is the bound itself)", "spec",
         "i:\n  type: int\n  default_value: 30\n  validation:\n    gt<>: [25]\n",
         {"ranges": {"i": (25, 2**63 - 1)}, "refuse": [("i", 25)], "accept": [("i", 26)]}),
    Case("gpl-descriptor-gt-eq-range", f"{DESC}: DescriptorTest.check_gt (gt_eq the same)", "spec",
         "i:\n  type: int\n  default_value: 3\n  validation:\n    gt_eq<>: [2]\n",
         {"ranges": {"i": (2, 2**63 - 1)}, "accept": [("i", 2)]}),
    Case("gpl-descriptor-lt-eq-double", f"{DESC}: DescriptorTest.check_lt_eq (on a double: the lowest double)",
         "spec", "d:\n  type: double\n  default_value: 0.0\n  validation:\n    lt_eq<>: [4.0]\n",
         {"ranges": {"d": (-1.7976931348623157e308, 4.0)}}),
    Case("gpl-mapped", f"{MAPPED}: test_get_dynamic_mapped_parameter_nested (pid.__map_joints.p: the root joints)", "spec",
         "joints:\n  type: string_array\n  default_value: [shoulder, elbow]\n"
         "gains:\n  __map_joints:\n    p:\n      type: double\n      default_value: 1.0\n",
         {"names": ["joints", "gains.shoulder.p", "gains.elbow.p"], "values": {"gains.elbow.p": ("double", 1.0)}}),
    Case("gpl-mapped-group-key", f"{MAPPED}: test_get_dynamic_mapped_parameter_nested (nested.__map_entries: nested.entries)",
         "spec", "cfg:\n  entries:\n    type: string_array\n    default_value: [e1]\n"
         "  __map_entries:\n    v:\n      type: int\n      default_value: 3\n",
         {"names": ["cfg.entries", "cfg.e1.v"]}),
    Case("gpl-mapped-deep-group-key", f"{MAPPED}: test_get_dynamic_mapped_parameter_nested (level1.level2.__map_items)",
         "spec", "l1:\n  l2:\n    things:\n      type: string_array\n      default_value: [t]\n"
         "    __map_things:\n      w:\n        type: bool\n        default_value: true\n",
         {"names": ["l1.l2.things", "l1.l2.t.w"]}),
    Case("gpl-mapped-group-key-preferred", f"{MAPPED}: test_get_dynamic_mapped_parameter_nested (the group's array first)",
         "spec", "things:\n  type: string_array\n  default_value: [root_one]\n"
         "grp:\n  things:\n    type: string_array\n    default_value: [grp_one]\n"
         "  __map_things:\n    w:\n      type: int\n      default_value: 1\n",
         {"names": ["things", "grp.things", "grp.grp_one.w"]}),
    Case("gpl-mapped-override", f"{MAPPED}: mapped parameters take their value from overrides", "spec",
         "joints:\n  type: string_array\n  default_value: [a]\n"
         "gains:\n  __map_joints:\n    p:\n      type: double\n      default_value: 1.0\n",
         {"overrides": {"joints": ["j1", "j2"], "gains.j2.p": 7.5},
          "names": ["joints", "gains.j1.p", "gains.j2.p"], "values": {"gains.j2.p": ("double", 7.5)}}),
    Case("gpl-mapped-validated", f"{NESTED_MAP}: test_single_map_parameter_names (a mapped leaf keeps its validation)", "spec",
         "joints:\n  type: string_array\n  default_value: [a]\n"
         "lim:\n  __map_joints:\n    v:\n      type: double\n      default_value: 1.0\n"
         "      validation:\n        gt_eq<>: [0.0]\n", {"accept": [("lim.a.v", 2.0)], "refuse": [("lim.a.v", -1.0)]}),
    Case("gpl-nested-map", f"{NESTED_MAP}: test_nested_map_parameter_names (a leaf and a nested map side by side)", "spec",
         "arms:\n  type: string_array\n  default_value: [left, right]\n"
         "axes:\n  type: string_array\n  default_value: [x]\n"
         "k:\n  __map_arms:\n    limit:\n      type: double\n      default_value: 1.0\n"
         "    __map_axes:\n      gain:\n        type: int\n        default_value: 0\n",
         {"names": ["arms", "axes", "k.left.limit", "k.right.limit", "k.left.x.gain", "k.right.x.gain"]}),
    Case("gpl-nested-map-undeclared-keys", f"{NESTED_MAP}: test_nested_map_parameter_names (the keys are not declared)",
         "spec", "k:\n  __map_arms:\n    limit:\n      type: double\n      default_value: 1.0\n",
         {"names": []},
         deliberate="a spec's `__map_<key>` must name a string-array parameter the same spec declares",
         ours=ERROR),
    Case("gpl-map-unknown-key", f"{MAPPED}: test_get_dynamic_mapped_parameter_nested (the key resolves to a declared array)", "spec",
         "gains:\n  __map_joints:\n    p:\n      type: double\n      default_value: 1.0\n", ERROR),
    Case("gpl-custom-unknown-loads", f"{PARSE}: custom, namespace-qualified validators are not checked", "spec",
         "t:\n  type: int\n  default_value: 1\n  validation:\n    my_pkg::never_registered<>: [1]\n",
         {"accept": [("t", 99)]}),
    Case("gpl-custom-gt-eq-or-nan", CONTROL, "spec",
         "t:\n  type: double\n  default_value: .nan\n  validation:\n    control_filters::gt_eq_or_nan<>: [0.0]\n",
         {"accept": [("t", float("nan")), ("t", 0.0)], "refuse": [("t", -1.0)]}),
    Case("gpl-custom-lt-eq-or-nan", CONTROL, "spec",
         "t:\n  type: double\n  default_value: .nan\n  validation:\n    control_filters::lt_eq_or_nan<>: [0.0]\n",
         {"accept": [("t", float("nan")), ("t", -3.0)], "refuse": [("t", 0.5)]}),
]

CASES: list[Case] = [*VALIDATORS, *SPECS, *CONFIGS]
