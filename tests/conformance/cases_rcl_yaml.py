# ruff: noqa: E501  (data tables: one case per entry reads better than wrapped)
"""Cases from ros2/rcl ``rcl_yaml_param_parser/test/`` (our own files, same shapes and outcomes).

Each file below is written by us; it has the structure of the upstream fixture the test
loads, with our own names and values, and expects what the upstream test asserts.
"""

from __future__ import annotations

from .runner import ERROR, Case

PARSE = "ros2/rcl rcl_yaml_param_parser/test/test_parse_yaml.cpp"
PARSE_C = "ros2/rcl rcl_yaml_param_parser/src/parse.c"
PARSE_UNIT = "ros2/rcl rcl_yaml_param_parser/test/test_parse.cpp"
WILD = f"{PARSE}: test_file_parser.wildcards"
PARTIAL = f"{PARSE}: test_file_parser.wildcards_partial"

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
    Case("rcl-wildcard-all", f"{WILD} (/** applies to every node)", "yaml",
         ("/**:\n  ros__parameters:\n    shared: 1\n", "deep/ns/any_node"), {"shared": ("integer", 1)}),
    Case("rcl-wildcard-all-root-node", f"{WILD} (/** applies to every node)", "yaml",
         ("/**:\n  ros__parameters:\n    shared: 1\n", "top"), {"shared": ("integer", 1)}),
    Case("rcl-wildcard-single-one-level", f"{WILD} (/* matches one token)", "yaml",
         ("/*:\n  ros__parameters:\n    one: 1\n", "top"), {"one": ("integer", 1)}),
    Case("rcl-wildcard-single-not-two-levels", f"{WILD} (/* matches one token)", "yaml",
         ("/*:\n  ros__parameters:\n    one: 1\n", "ns/top"), {}),
    Case("rcl-wildcard-ns-star", f"{WILD} (/ns/* matches the nodes of ns)", "yaml",
         ("/ns/*:\n  ros__parameters:\n    k: 2\n", "ns/n1"), {"k": ("integer", 2)}),
    Case("rcl-wildcard-ns-star-other-ns", f"{WILD} (/ns/* matches the nodes of ns)", "yaml",
         ("/ns/*:\n  ros__parameters:\n    k: 2\n", "other/n1"), {}),
    Case("rcl-wildcard-star-star-node", f"{WILD} (/**/node in any namespace)", "yaml",
         ("/**/arm:\n  ros__parameters:\n    k: 3\n", "a/b/arm"), {"k": ("integer", 3)}),
    Case("rcl-wildcard-star-star-node-root", f"{WILD} (/**/node in any namespace)", "yaml",
         ("/**/arm:\n  ros__parameters:\n    k: 3\n", "arm"), {"k": ("integer", 3)}),
    Case("rcl-wildcard-star-star-node-other", f"{WILD} (/**/node in any namespace)", "yaml",
         ("/**/arm:\n  ros__parameters:\n    k: 3\n", "a/leg"), {}),
    Case("rcl-wildcard-key-twice-merged", f"{WILD} (the fixture writes /** several times)", "yaml",
         ("/**:\n  ros__parameters:\n    a: 1\n/**:\n  ros__parameters:\n    b: 2\n", "n"),
         {"a": ("integer", 1), "b": ("integer", 2)}),
    Case("rcl-node-key-twice-later-wins", f"{WILD} (a node key written twice is merged)",
         "yaml", ("n:\n  ros__parameters:\n    a: 1\nn:\n  ros__parameters:\n    a: 5\n", "n"),
         {"a": ("integer", 5)}),
    Case("rcl-specific-after-wildcard-wins", f"{WILD} (a later section overrides)", "yaml",
         ("/**:\n  ros__parameters:\n    a: 1\nn:\n  ros__parameters:\n    a: 2\n", "n"), {"a": ("integer", 2)}),
    Case("rcl-wildcard-after-specific-wins", f"{WILD} (a later section overrides)", "yaml",
         ("n:\n  ros__parameters:\n    a: 2\n/**:\n  ros__parameters:\n    a: 1\n", "n"), {"a": ("integer", 1)}),
    Case("rcl-bool-words", f"{PARSE_C}: get_value (the YAML 1.1 bool words)", "yaml",
         ("p:\n  ros__parameters:\n    a: yes\n    b: Off\n    c: TRUE\n", "p"),
         {"a": ("bool", True), "b": ("bool", False), "c": ("bool", True)}),
    Case("rcl-hex-int", f"{PARSE_C}: get_value (integers by strtoll, base 0)", "yaml",
         ("p:\n  ros__parameters:\n    h: 0x10\n", "p"), {"h": ("integer", 16)}),
    Case("rcl-exponent-double", f"{PARSE_C}: get_value (doubles by strtod)", "yaml",
         ("p:\n  ros__parameters:\n    d: 2e3\n", "p"), {"d": ("double", 2000.0)}),
    Case("rcl-mixed-int-double-list", f"{PARSE_UNIT}: TestParse.parse_value_sequence (a sequence keeps one type)", "yaml",
         ("p:\n  ros__parameters:\n    m: [1, 2.5]\n", "p"), ERROR),
    Case("rcl-mixed-bool-string-list", f"{PARSE_UNIT}: TestParse.parse_value_sequence (a sequence keeps one type)", "yaml",
         ("p:\n  ros__parameters:\n    m: [true, word]\n", "p"), ERROR),
    Case("rcl-tagged-str", f"{PARSE}: test_parser.correct_syntax (string_tag: !!str keeps a string)", "yaml",
         ("p:\n  ros__parameters:\n    s: !!str 12\n", "p"), {"s": ("string", "12")}),
    Case("rcl-unknown-tag", f"{PARSE_C}: parse_file_events (only !!str changes the typing; any other "
         "tag is ignored, as rcl 10.1.3 shows)", "yaml",
         ("p:\n  ros__parameters:\n    s: !!binary 12\n    t: !!float 1\n    u: !custom [1, 2]\n", "p"),
         {"s": ("integer", 12), "t": ("integer", 1), "u": ("integer_array", [1, 2])}),
    Case("rcl-empty-name-in-ns", f"{PARSE}: test_file_parser.empty_name_in_ns", "yaml",
         ("ns:\n  \"\":\n    ros__parameters:\n      a: 1\n", "ns"), ERROR),
    Case("rcl-tag-str-bool-word", f"{PARSE}: test_parser.correct_syntax (string_tag)", "yaml",
         ("tagged:\n  ros__parameters:\n    w: !!str on\n    n: !!str 4321\n    d: !!str 43.21\n", "tagged"),
         {"w": ("string", "on"), "n": ("string", "4321"), "d": ("string", "43.21")}),
    Case("rcl-parse-value-scalars", f"{PARSE_UNIT}: TestParse.parse_value", "yaml",
         ("p:\n  ros__parameters:\n    b: true\n    i: 17\n    d: 2.71828\n    s: hi, a plain string\n", "p"),
         {"b": ("bool", True), "i": ("integer", 17), "d": ("double", 2.71828), "s": ("string", "hi, a plain string")}),
    Case("rcl-wildcard-params-and-child", f"{WILD} (/** holds ros__parameters and a child node)", "yaml",
         ("/**:\n  ros__parameters:\n    g: 1\n  child_a:\n    ros__parameters:\n      k: 2\n", "x/child_a"),
         {"g": ("integer", 1), "k": ("integer", 2)}),
    Case("rcl-wildcard-child-before-params", f"{WILD} (the child node written before ros__parameters)", "yaml",
         ("/*:\n  child_b:\n    ros__parameters:\n      k: 2\n  ros__parameters:\n    g: 1\n", "x/child_b"),
         {"k": ("integer", 2)}),
    Case("rcl-wildcard-quoted-star-child", f"{WILD} (a quoted \"*\" under a namespace)", "yaml",
         ("/ns9:\n  \"*\":\n    ros__parameters:\n      k: 3\n", "ns9/whatever"), {"k": ("integer", 3)}),
    Case("rcl-wildcard-child-with-slashes", f"{WILD} (a child key holding slashes and **)", "yaml",
         ("/top/**/mid:\n  a1/a2/**:\n    ros__parameters:\n      k: 4\n", "top/x/mid/a1/a2/y"),
         {"k": ("integer", 4)}),
    Case("rcl-wildcard-ns-star-star", f"{WILD} (/ns/** matches the nodes under ns)", "yaml",
         ("/grp/**:\n  ros__parameters:\n    k: 5\n", "grp/a/b"), {"k": ("integer", 5)}),
    Case("rcl-wildcard-node-slash", f"{PARSE}: test_file_parser.wildcards_node_slash", "yaml",
         ("/base:\n  /*:\n    ros__parameters:\n      k: 1\n", "base/x"), ERROR),
    *[Case(f"rcl-wildcard-partial-{i}", PARTIAL, "yaml", (f"{key}:\n  ros__parameters:\n    k: 1\n", "x"), ERROR)
      for i, key in enumerate(["/arm**", "/**arm", "/a*rm", "/*arm", "/arm*", "/**/ar*m", "/grp/**x", "/x*/arm"])],
]
