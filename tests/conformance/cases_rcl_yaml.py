# ruff: noqa: E501  (data tables: one case per entry reads better than wrapped)
"""Cases from ros2/rcl ``rcl_yaml_param_parser/test/`` (our own files, same shapes and outcomes).

Each file below is written by us; it has the structure of the upstream fixture the test
loads, with our own names and values, and expects what the upstream test asserts.
"""

from __future__ import annotations

from .runner import ERROR, Case

PARSE = "ros2/rcl rcl_yaml_param_parser/test/test_parse_yaml.cpp"
PARSER = "ros2/rcl rcl_yaml_param_parser/test/test_parser.cpp"

_NESTED = """\
sensors_ns:
  rangefinder_a:
    ros__parameters:
      mirrored: true
      unit: 7
      feed.ports: [5101, 5102]
      feed:
        bias: [3.5, -1.25, 0.75]
turret:
  ros__parameters:
    side: left
    optics:
      tilt: 1.75
      vendors: ["Acme", "Globex"]
    flags: [true, false, true]
"""

CASES: list[Case] = [
    Case("rcl-correct-bool", f"{PARSE}: test_parser.correct_syntax", "yaml",
         (_NESTED, "sensors_ns/rangefinder_a"),
         {"mirrored": ("bool", True), "unit": ("integer", 7), "feed.ports": ("integer_array", [5101, 5102]),
          "feed.bias": ("double_array", [3.5, -1.25, 0.75])}),
    Case("rcl-correct-plain-node", f"{PARSE}: test_parser.correct_syntax", "yaml", (_NESTED, "turret"),
         {"side": ("string", "left"), "optics.tilt": ("double", 1.75),
          "optics.vendors": ("string_array", ["Acme", "Globex"]), "flags": ("bool_array", [True, False, True])}),
    Case("rcl-correct-other-node-gets-nothing", f"{PARSE}: test_parser.correct_syntax", "yaml",
         (_NESTED, "elsewhere"), {}),
    Case("rcl-quoted-number-in-string-array", f"{PARSE}: test_file_parser.string_array_with_quoted_number",
         "yaml", ("probe:\n  ros__parameters:\n    tags: [\"word\", \"42\"]\n", "probe"),
         {"tags": ("string_array", ["word", "42"])}),
    Case("rcl-quoted-zero-is-string", f"{PARSE}: test_file_parser.string_array_with_quoted_number", "yaml",
         ("probe:\n  ros__parameters:\n    group: '0'\n", "probe"), {"group": ("string", "0")}),
    Case("rcl-multi-ns", f"{PARSE}: test_file_parser.multi_ns_correct_syntax", "yaml",
         ("outer:\n  inner:\n    leaf_node:\n      ros__parameters:\n        gain: 2\n", "outer/inner/leaf_node"),
         {"gain": ("integer", 2)}),
    Case("rcl-root-ns", f"{PARSE}: test_file_parser.root_ns", "yaml",
         ("/:\n  solo_node:\n    ros__parameters:\n      rate: 9\n", "solo_node"), {"rate": ("integer", 9)}),
    Case("rcl-root-ns-one-slash", f"{PARSE}: test_file_parser.root_ns", "yaml",
         ("/:\n  solo_node:\n    ros__parameters:\n      rate: 9\n", "/solo_node"), {"rate": ("integer", 9)}),
    Case("rcl-seq-of-maps-1", f"{PARSE}: test_file_parser.seq_map1", "yaml",
         ("probe:\n  ros__parameters:\n    items:\n      - a: 1\n      - b: 2\n", "probe"), ERROR),
    Case("rcl-seq-of-maps-2", f"{PARSE}: test_file_parser.seq_map2", "yaml",
         ("probe:\n  ros__parameters:\n    items: [1, {b: 2}]\n", "probe"), ERROR),
    Case("rcl-params-without-node", f"{PARSE}: test_file_parser.params_with_no_node", "yaml",
         ("ros__parameters:\n  gain: 1\n", "probe"), ERROR),
    Case("rcl-no-alias", f"{PARSE}: test_file_parser.no_alias_support", "yaml",
         ("probe:\n  ros__parameters:\n    first: &shared 3\n    second: *shared\n", "probe"), ERROR),
    Case("rcl-no-alias-of-a-list", f"{PARSE}: test_file_parser.no_alias_support", "yaml",
         ("probe:\n  ros__parameters:\n    a: &l [1, 2]\n    b: *l\n", "probe"), ERROR),
    Case("rcl-empty-string", f"{PARSE}: test_file_parser.empty_string", "yaml",
         ("probe:\n  ros__parameters:\n    label: \"\"\n", "probe"), {"label": ("string", "")}),
    Case("rcl-no-value", f"{PARSE}: test_file_parser.no_value1", "yaml",
         ("probe:\n  ros__parameters:\n    gain:\n", "probe"), ERROR),
    Case("rcl-indented-ns", f"{PARSE}: test_file_parser.indented_ns", "yaml",
         ("probe:\n  ros__parameters:\n    gain: 1\n   bad: 2\n", "probe"), ERROR),
    Case("rcl-special-float-nan-inf", f"{PARSE}: test_file_parser.special_float_point", "yaml",
         ("probe:\n  ros__parameters:\n    v: [1.5, .nan, .NaN, .inf, -.inf, .Inf]\n", "probe"),
         {"v": ("double_array", [1.5, float("nan"), float("nan"), float("inf"), float("-inf"), float("inf")])}),
    Case("rcl-special-float-lookalikes-are-strings", f"{PARSE}: test_file_parser.special_float_point", "yaml",
         ("probe:\n  ros__parameters:\n    s: [plain, .nanx, .nAN, .infx, .INf]\n", "probe"),
         {"s": ("string_array", ["plain", ".nanx", ".nAN", ".infx", ".INf"])}),
    Case("rcl-special-float-scalar-nan", f"{PARSE}: test_file_parser.special_float_point", "yaml",
         ("probe:\n  ros__parameters:\n    v: .NAN\n", "probe"), {"v": ("double", float("nan"))}),
    Case("rcl-special-float-scalar-neg-inf", f"{PARSE}: test_file_parser.special_float_point", "yaml",
         ("probe:\n  ros__parameters:\n    v: -.Inf\n", "probe"), {"v": ("double", float("-inf"))}),
    Case("rcl-wildcard-all", f"{PARSER}: wildcards (/** applies to every node)", "yaml",
         ("/**:\n  ros__parameters:\n    shared: 1\n", "deep/ns/any_node"), {"shared": ("integer", 1)}),
    Case("rcl-wildcard-all-root-node", f"{PARSER}: wildcards (/** applies to every node)", "yaml",
         ("/**:\n  ros__parameters:\n    shared: 1\n", "top"), {"shared": ("integer", 1)}),
    Case("rcl-wildcard-single-one-level", f"{PARSER}: wildcards (/* matches one token)", "yaml",
         ("/*:\n  ros__parameters:\n    one: 1\n", "top"), {"one": ("integer", 1)}),
    Case("rcl-wildcard-single-not-two-levels", f"{PARSER}: wildcards (/* matches one token)", "yaml",
         ("/*:\n  ros__parameters:\n    one: 1\n", "ns/top"), {}),
    Case("rcl-wildcard-ns-star", f"{PARSER}: wildcards (/ns/* matches nodes in ns)", "yaml",
         ("/ns/*:\n  ros__parameters:\n    k: 2\n", "ns/n1"), {"k": ("integer", 2)}),
    Case("rcl-wildcard-ns-star-other-ns", f"{PARSER}: wildcards (/ns/* matches nodes in ns)", "yaml",
         ("/ns/*:\n  ros__parameters:\n    k: 2\n", "other/n1"), {}),
    Case("rcl-wildcard-star-star-node", f"{PARSER}: wildcards (/**/node in any namespace)", "yaml",
         ("/**/arm:\n  ros__parameters:\n    k: 3\n", "a/b/arm"), {"k": ("integer", 3)}),
    Case("rcl-wildcard-star-star-node-root", f"{PARSER}: wildcards (/**/node in any namespace)", "yaml",
         ("/**/arm:\n  ros__parameters:\n    k: 3\n", "arm"), {"k": ("integer", 3)}),
    Case("rcl-wildcard-star-star-node-other", f"{PARSER}: wildcards (/**/node in any namespace)", "yaml",
         ("/**/arm:\n  ros__parameters:\n    k: 3\n", "a/leg"), {}),
    Case("rcl-wildcard-key-twice-merged", f"{PARSER}: wildcards (wildcards.yaml writes /** twice)", "yaml",
         ("/**:\n  ros__parameters:\n    a: 1\n/**:\n  ros__parameters:\n    b: 2\n", "n"),
         {"a": ("integer", 1), "b": ("integer", 2)}),
    Case("rcl-node-key-twice-later-wins", f"{PARSER}: wildcards (a node key written twice is merged)",
         "yaml", ("n:\n  ros__parameters:\n    a: 1\nn:\n  ros__parameters:\n    a: 5\n", "n"),
         {"a": ("integer", 5)}),
    Case("rcl-specific-after-wildcard-wins", f"{PARSER}: wildcards (later section overrides)", "yaml",
         ("/**:\n  ros__parameters:\n    a: 1\nn:\n  ros__parameters:\n    a: 2\n", "n"), {"a": ("integer", 2)}),
    Case("rcl-wildcard-after-specific-wins", f"{PARSER}: wildcards (later section overrides)", "yaml",
         ("n:\n  ros__parameters:\n    a: 2\n/**:\n  ros__parameters:\n    a: 1\n", "n"), {"a": ("integer", 1)}),
    Case("rcl-bool-words", f"{PARSER}: test_correct_syntax (bool spellings)", "yaml",
         ("p:\n  ros__parameters:\n    a: yes\n    b: Off\n    c: TRUE\n", "p"),
         {"a": ("bool", True), "b": ("bool", False), "c": ("bool", True)}),
    Case("rcl-hex-int", f"{PARSER}: test_correct_syntax (integers as strtoll base 0)", "yaml",
         ("p:\n  ros__parameters:\n    h: 0x10\n", "p"), {"h": ("integer", 16)}),
    Case("rcl-exponent-double", f"{PARSER}: test_correct_syntax (doubles as strtod)", "yaml",
         ("p:\n  ros__parameters:\n    d: 2e3\n", "p"), {"d": ("double", 2000.0)}),
    Case("rcl-mixed-int-double-list", f"{PARSER}: test_correct_syntax (arrays are homogeneous)", "yaml",
         ("p:\n  ros__parameters:\n    m: [1, 2.5]\n", "p"), ERROR),
    Case("rcl-mixed-bool-string-list", f"{PARSER}: test_correct_syntax (arrays are homogeneous)", "yaml",
         ("p:\n  ros__parameters:\n    m: [true, word]\n", "p"), ERROR),
    Case("rcl-tagged-str", f"{PARSER}: tag_incorrect_config (!!str keeps a string)", "yaml",
         ("p:\n  ros__parameters:\n    s: !!str 12\n", "p"), {"s": ("string", "12")}),
    Case("rcl-unknown-tag", f"{PARSER}: tag_incorrect_config_01..05", "yaml",
         ("p:\n  ros__parameters:\n    s: !!binary 12\n", "p"), ERROR),
    Case("rcl-empty-name-in-ns", f"{PARSER}: empty_name_in_ns", "yaml",
         ("ns:\n  \"\":\n    ros__parameters:\n      a: 1\n", "ns"), ERROR),
    Case("rcl-invalid-node-name", f"{PARSER}: invalid node name", "yaml",
         ("9node:\n  ros__parameters:\n    a: 1\n", "x"), ERROR),
    Case("rcl-value-at-node-level", f"{PARSER}: invalid_map1/invalid_map2", "yaml",
         ("probe: 3\n", "probe"), ERROR),
    Case("rcl-dotted-key", "ros2/rcl rcl_yaml_param_parser/test/test_parse.cpp: parameter names with dots",
         "yaml", ("p:\n  ros__parameters:\n    lin.x.max: 1.0\n", "p"), {"lin.x.max": ("double", 1.0)}),
]
