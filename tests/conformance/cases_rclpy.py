# ruff: noqa: E501  (data tables: one case per entry reads better than wrapped)
"""Cases from ros2/rclpy ``test/test_node.py`` and ``test/test_parameter.py`` (our own values).

Where rclpy and rclcpp disagree we follow rclcpp, and the case says so.
"""

from __future__ import annotations

from .runner import Case

NODE = "ros2/rclpy rclpy/test/test_node.py"
PARAM = "ros2/rclpy rclpy/test/test_parameter.py"
LISTING = ("ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: NodeParameters::list_parameters "
           "(the prefix and depth rules rclpy ports; no upstream test pins these combinations)")

_NAMES = ["use_sim_time", "alpha_grp.x", "alpha_grp.y", "alpha_grp.deep.z", "beta_grp.x", "beta_grp.y",
          "gamma"]


def _int_range() -> list[Case]:
    src = f"{NODE}: TestNode.test_integer_range_descriptor"
    rows = [((0, 10, 2), 0, [(0, True), (4, True), (10, True), (5, False), (12, False), (-2, False)]),
            ((-20, 0, 30), -20, [(-20, True), (0, True), (-8, False), (30, False)]),
            ((-20, 20, 0), -20, [(7, True), (20, True), (21, False)])]
    return [Case(f"rclpy-int-range-{lo}-{hi}-{step}-{v}", src, "range",
                 {"type": "integer", "range": (lo, hi, step), "default": d, "value": v}, ok)
            for (lo, hi, step), d, sets in rows for v, ok in sets]


def _fp_range() -> list[Case]:
    src = f"{NODE}: TestNode.test_floating_point_range_descriptor"
    rows = [((0.0, 10.0, 0.5), 0.0, [(0.0, True), (3.5, True), (10.0, True), (3.25, False), (12.5, False),
                                     (-0.5, False), (1.0000000001, True)]),
            ((-20.0, 0.0, 30.0), -20.0, [(-20.0, True), (0.0, True), (-8.5, False), (30.0, False)]),
            ((-20.0, 20.0, 0.0), -20.0, [(6.37, True), (20.0, True), (20.5, False)])]
    return [Case(f"rclpy-fp-range-{lo}-{hi}-{step}-{v}", src + (" (within 1e-6, PARAM_REL_TOL)" if v == 1.0000000001 else ""),
                 "range", {"type": "double", "range": (lo, hi, step), "default": d, "value": v}, ok)
            for (lo, hi, step), d, sets in rows for v, ok in sets]


def _listing() -> list[Case]:
    rows: list[tuple[str, list[str], int, list[str], list[str]]] = [
        ("all", [], 0, _NAMES, ["alpha_grp", "alpha_grp.deep", "beta_grp"]),
        ("depth1", [], 1, ["use_sim_time", "gamma"], []),
        ("depth2", [], 2, ["use_sim_time", "gamma", "alpha_grp.x", "alpha_grp.y", "beta_grp.x", "beta_grp.y"],
         ["alpha_grp", "beta_grp"]),
        ("prefix", ["alpha_grp"], 0, ["alpha_grp.x", "alpha_grp.y", "alpha_grp.deep.z"],
         ["alpha_grp", "alpha_grp.deep"]),
        ("prefix-depth1", ["alpha_grp"], 1, ["alpha_grp.x", "alpha_grp.y"], ["alpha_grp"]),
        ("two-prefixes", ["alpha_grp", "beta_grp"], 1, ["alpha_grp.x", "alpha_grp.y", "beta_grp.x", "beta_grp.y"],
         ["alpha_grp", "beta_grp"]),
        ("prefix-no-match", ["delta"], 0, [], []),
        ("prefix-is-a-name", ["gamma"], 0, ["gamma"], []),
        ("prefix-not-a-word-prefix", ["alpha"], 0, [], []),
        ("deep-prefix", ["alpha_grp.deep"], 1, ["alpha_grp.deep.z"], ["alpha_grp.deep"]),
    ]
    return [Case(f"rclpy-list-{key}", LISTING, "list", (_NAMES, prefixes, depth), (names, found))
            for key, prefixes, depth, names, found in rows]


YAML_DICT = f"{PARAM}: TestParameter.test_parameter_dict_from_yaml_file (target_nodes, wildcards on)"
_TARGETS = """\
/tgt:
  ros__parameters:
    abs_node: true
tgt:
  ros__parameters:
    base_node: true
/ns1/tgt:
  ros__parameters:
    abs_ns1_node: true
/ns1:
  tgt:
    ros__parameters:
      abs_ns1_base: true
/ns2/tgt:
  ros__parameters:
    abs_ns2_node: false
/**:
  ros__parameters:
    everywhere: true
/*:
  tgt2:
    ros__parameters:
      star_ns_base: false
/**/tgt3:
  ros__parameters:
    anyns_tgt3: true
/q1:
  tgt2:
    ros__parameters:
      q1_base: true
/**/tgt2:
  ros__parameters:
    anyns_tgt2: false
/w/x/y/z:
  tgt3:
    ros__parameters:
      deep_base_tgt3: false
tgt3:
  ros__parameters:
    base_tgt3: true
"""


def _bools(**names: bool) -> dict[str, tuple[str, bool]]:
    return {n: ("bool", v) for n, v in names.items()}


TARGETS: list[Case] = [
    Case("rclpy-targets-root-node", YAML_DICT, "yaml", (_TARGETS, "tgt"),
         _bools(everywhere=True, abs_node=True, base_node=True)),
    Case("rclpy-targets-namespaced", YAML_DICT, "yaml", (_TARGETS, "/ns1/tgt"),
         _bools(everywhere=True, abs_ns1_node=True, abs_ns1_base=True)),
    Case("rclpy-targets-single-level-ns", YAML_DICT, "yaml", (_TARGETS, "/q1/tgt2"),
         _bools(everywhere=True, star_ns_base=False, q1_base=True, anyns_tgt2=False)),
    Case("rclpy-targets-deep-ns", YAML_DICT, "yaml", (_TARGETS, "/w/x/y/z/tgt3"),
         _bools(everywhere=True, anyns_tgt3=True, deep_base_tgt3=False)),
    Case("rclpy-targets-root-node-and-star-star", YAML_DICT, "yaml", (_TARGETS, "tgt3"),
         _bools(everywhere=True, base_tgt3=True, anyns_tgt3=True),
         note="rclpy leaves out /**/tgt3 for the root node tgt3; rclcpp's parameter_map_from turns /** "
              "into (/\\w+)* and so matches it (zero namespaces). We follow rclcpp."),
]

CASES: list[Case] = [
    *TARGETS,
    *_int_range(),
    *_fp_range(),
    *_listing(),
    Case("rclpy-declare-value", f"{NODE}: TestNode.test_declare_parameter", "table", {},
         [("declare", "p1", "abc", "ok"), ("get", "p1", ("string", "abc"))]),
    Case("rclpy-declare-twice", f"{NODE}: TestNode.test_declare_parameter", "table", {},
         [("declare", "p1", 1, "ok"), ("declare", "p1", 2, "ALREADY_DECLARED")]),
    Case("rclpy-declare-invalid-name", f"{NODE}: TestNode.test_declare_parameter", "table", {},
         [("declare", "bad name!", 1, "INVALID_NAME")]),
    Case("rclpy-declare-type-only", f"{NODE}: TestNode.test_static_dynamic_typing (int_param_no_default)", "table", {},
         [("declare", "t", None, {"type": "integer"}, "ok"), ("has", "t", True), ("get", "t", "INVALID_VALUE"),
          ("set", "t", "asd", False), ("set", "t", 3, True), ("get", "t", ("integer", 3)), ("set", "t", None, False)]),
    Case("rclpy-static-int-param", f"{NODE}: TestNode.test_static_dynamic_typing (int_param)", "table", {},
         [("declare", "i", 0, "ok"), ("set", "i", "asd", False), ("set", "i", 3, True)]),
    Case("rclpy-set-many-with-undeclared", f"{NODE}: TestNode.test_node_set_parameters (the fourth is not declared)",
         "table", {}, [("declare", "foo", 42, "ok"), ("declare", "bar", "hello", "ok"), ("declare", "baz", 2.41, "ok"),
                       ("set_many", [("foo", 24), ("bar", "bye"), ("baz", 1.42), ("foobar", 1.42)], [True, True, True, False]),
                       ("get", "baz", ("double", 1.42)), ("has", "foobar", False)]),
    Case("rclpy-set-many-read-only", f"{NODE}: TestNode.test_node_set_parameters_read_only", "table", {},
         [("declare", "imm_a", 42, {"read_only": True}, "ok"), ("declare", "b", "hello", "ok"),
          ("declare", "imm_c", 2.41, {"read_only": True}, "ok"),
          ("set_many", [("imm_a", 24), ("b", "bye"), ("imm_c", 1.42)], [False, True, False]),
          ("get", "imm_a", ("integer", 42)), ("get", "b", ("string", "bye"))]),
    Case("rclpy-atomic-with-undeclared", f"{NODE}: TestNode.test_node_set_parameters_atomically (the fourth is not declared)",
         "table", {}, [("declare", "foo", 42, "ok"), ("declare", "bar", "hello", "ok"),
                       ("atomic", [("foo", 24), ("bar", "bye"), ("foobar", 1.42)], False),
                       ("get", "foo", ("integer", 42)), ("has", "foobar", False)]),
    Case("rclpy-declare-dynamic-unset", f"{NODE}: TestNode.test_static_dynamic_typing (dynamic_param)",
         "table", {}, [("declare", "x", None, {"dynamic_typing": True}, "ok"), ("type", "x", "not_set")]),
    Case("rclpy-read-only", f"{NODE}: TestNode.test_node_set_parameters_read_only", "table", {},
         [("declare", "r", 3, {"read_only": True}, "ok"), ("set", "r", 4, False), ("get", "r", ("integer", 3))]),
    Case("rclpy-read-only-atomic", f"{NODE}: TestNode.test_node_set_parameters_atomically_read_only", "table", {},
         [("declare", "r", 3, {"read_only": True}, "ok"), ("declare", "w", 1, "ok"),
          ("atomic", [("w", 2), ("r", 4)], False), ("get", "w", ("integer", 1))]),
    Case("rclpy-set-undeclared", f"{NODE}: TestNode.test_node_set_undeclared_parameters", "table", {},
         [("set", "ghost", 1, False)]),
    Case("rclpy-set-undeclared-allowed", f"{NODE}: TestNode.test_node_set_undeclared_parameters "
         "(allow_undeclared_parameters)", "table", {"options": {"allow_undeclared": True}},
         [("set", "ghost", 1.5, True), ("get", "ghost", ("double", 1.5))]),
    Case("rclpy-static-type-change", f"{NODE}: TestNode.test_static_dynamic_typing (a static type stays)", "table", {},
         [("declare", "s", 1, "ok"), ("set", "s", 1.5, False), ("set", "s", "x", False), ("set", "s", 2, True)]),
    Case("rclpy-dynamic-type-change", f"{NODE}: TestNode.test_static_dynamic_typing", "table", {},
         [("declare", "d", 1, {"dynamic_typing": True}, "ok"), ("set", "d", "x", True), ("set", "d", [1, 2], True),
          ("get", "d", ("integer_array", [1, 2]))]),
    Case("rclpy-undeclare", f"{NODE}: TestNode.test_node_undeclare_parameter_has_parameter", "table", {},
         [("declare", "d", 1, {"dynamic_typing": True}, "ok"), ("undeclare", "d", "ok"),
          ("undeclare", "d", "NOT_FOUND")]),
    Case("rclpy-undeclare-read-only", f"{NODE}: TestNode.test_node_undeclare_parameter_has_parameter (read only)", "table", {},
         [("declare", "r", 1, {"read_only": True, "dynamic_typing": True}, "ok"), ("undeclare", "r", "READ_ONLY")]),
    Case("rclpy-undeclare-static", f"{NODE}: TestNode.test_node_undeclare_parameter_has_parameter "
         "(a statically typed 'foo' is undeclared)", "table", {},
         [("declare", "s", "hello", "ok"), ("undeclare", "s", "TYPE_MISMATCH"), ("has", "s", True)],
         note="rclpy undeclares a statically typed parameter; rclcpp throws InvalidParameterTypeException "
              "(TestNode.undeclare_parameter, 'statically typed parameter throws'). We follow rclcpp."),
    Case("rclpy-declare-type-wrong-override", f"{NODE}: TestNode.test_declare_parameters (initial_decl_wrong_type)",
         "table", {"overrides": {"w": "text"}}, [("declare", "w", None, {"type": "integer"}, "TYPE_MISMATCH")]),
    Case("rclpy-declare-type-override", f"{NODE}: TestNode.test_declare_parameters (initial_decl_with_type)",
         "table", {"overrides": {"w": 3.25}}, [("declare", "w", None, {"type": "double"}, "ok"),
                                               ("get", "w", ("double", 3.25))]),
    Case("rclpy-declare-ignore-override", f"{NODE}: TestNode.test_declare_parameter (initial_bar, ignore_override)",
         "table", {"overrides": {"b": "from file"}}, [("declare_ignoring_override", "b", "kept", "ok"),
                                                      ("get", "b", ("string", "kept"))]),
    Case("rclpy-describe-unknown", f"{NODE}: TestNode.test_describe_parameter (ParameterNotDeclaredException)", "table", {},
         [("describe", "ghost", "NOT_FOUND")]),
    Case("rclpy-describe", f"{NODE}: TestNode.test_describe_parameter", "table", {},
         [("declare", "p", "v", {"description": "words", "additional_constraints": "short"}, "ok"),
          ("describe", "p", {"type": "string", "description": "words", "additional_constraints": "short"})]),
    Case("rclpy-wrong-kind-fp-range-on-string", f"{NODE}: TestNode.test_floating_point_range_descriptor "
         "(non-floats are not affected by the range)", "table", {},
         [("declare", "s", "text", {"floating_point_range": (0.0, 10.0, 0.5)}, "ok"), ("set", "s", "more", True)]),
    Case("rclpy-wrong-kind-fp-range-on-int", f"{NODE}: TestNode.test_floating_point_range_descriptor "
         "(non-floats are not affected by the range)", "table", {},
         [("declare", "i", 123, {"floating_point_range": (0.0, 10.0, 0.5)}, "ok"), ("get", "i", ("integer", 123))]),
    Case("rclpy-wrong-kind-int-range-on-double", f"{NODE}: TestNode.test_integer_range_descriptor "
         "(non-integers are not affected by the range)", "table", {},
         [("declare", "d", 123.0, {"integer_range": (0, 10, 2)}, "ok"), ("set", "d", 9.5, True)]),
    Case("rclpy-wrong-kind-int-range-on-string", f"{NODE}: TestNode.test_integer_range_descriptor "
         "(non-integers are not affected by the range)", "table", {},
         [("declare", "s", "no integer", {"integer_range": (0, 10, 2)}, "ok"), ("get", "s", ("string", "no integer"))]),
    Case("rclpy-range-bad-declaration-refused", f"{NODE}: TestNode.test_integer_range_descriptor (out_of_range "
         "is not declared)", "table", {}, [("declare", "o", 30, {"integer_range": (-10, 0, 30)}, "OUT_OF_RANGE"),
                                             ("has", "o", False)]),
    Case("rclpy-byte-array", f"{PARAM}: TestParameter.test_create_bytes_parameter", "table", {},
         [("declare", "b", b"\x01\xff", "ok"), ("type", "b", "byte_array")]),
    Case("rclpy-bool-array", f"{PARAM}: TestParameter.test_create_boolean_array_parameter", "table", {},
         [("declare", "b", [True, False], "ok"), ("get", "b", ("bool_array", [True, False]))]),
    Case("rclpy-string-array", f"{PARAM}: TestParameter.test_create_string_array_parameter", "table", {},
         [("declare", "s", ["a", "b"], "ok"), ("get", "s", ("string_array", ["a", "b"]))]),
    Case("rclpy-double-array", f"{PARAM}: TestParameter.test_create_float_array_parameter", "table", {},
         [("declare", "d", [1.5, 2.5], "ok"), ("get", "d", ("double_array", [1.5, 2.5]))]),
    Case("rclpy-integer-array", f"{PARAM}: TestParameter.test_create_integer_array_parameter", "table", {},
         [("declare", "i", [1, 2], "ok"), ("get", "i", ("integer_array", [1, 2]))]),
    Case("rclpy-bool-is-not-int", f"{PARAM}: TestParameter.test_create_boolean_parameter", "table", {},
         [("declare", "b", True, "ok"), ("type", "b", "bool"), ("set", "b", 1, False)]),
]
