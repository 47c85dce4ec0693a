# ruff: noqa: E501  (data tables: one case per entry reads better than wrapped)
"""Cases from ros2/rclpy ``test/test_node.py`` and ``test/test_parameter.py`` (our own values).

Where rclpy and rclcpp disagree we follow rclcpp, and the case says so.
"""

from __future__ import annotations

from .runner import Case

NODE = "ros2/rclpy rclpy/test/test_node.py"
PARAM = "ros2/rclpy rclpy/test/test_parameter.py"
LISTING = f"{NODE}: TestNode.test_node_list_parameters"

_NAMES = ["use_sim_time", "alpha_grp.x", "alpha_grp.y", "alpha_grp.deep.z", "beta_grp.x", "beta_grp.y",
          "gamma"]


def _int_range() -> list[Case]:
    sets = [(0, True), (4, True), (10, True), (5, False), (12, False), (-2, False)]
    return [Case(f"rclpy-int-range-{v}", f"{NODE}: TestNode.test_integer_range_descriptor", "range",
                 {"type": "integer", "range": (0, 10, 2), "default": 0, "value": v}, ok) for v, ok in sets]


def _fp_range() -> list[Case]:
    sets = [(0.0, True), (3.5, True), (10.0, True), (3.7, False), (10.5, False), (-0.5, False),
            (1.0000000001, True)]
    return [Case(f"rclpy-fp-range-{v}", f"{NODE}: TestNode.test_floating_point_range_descriptor (tolerance "
                 "1e-6 as PARAM_REL_TOL)", "range",
                 {"type": "double", "range": (0.0, 10.0, 0.5), "default": 0.0, "value": v}, ok) for v, ok in sets]


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


CASES: list[Case] = [
    *_int_range(),
    *_fp_range(),
    *_listing(),
    Case("rclpy-declare-value", f"{NODE}: TestNode.test_declare_parameter", "table", {},
         [("declare", "p1", "abc", "ok"), ("get", "p1", ("string", "abc"))]),
    Case("rclpy-declare-twice", f"{NODE}: TestNode.test_declare_parameter", "table", {},
         [("declare", "p1", 1, "ok"), ("declare", "p1", 2, "ALREADY_DECLARED")]),
    Case("rclpy-declare-invalid-name", f"{NODE}: TestNode.test_declare_parameter", "table", {},
         [("declare", "bad name!", 1, "INVALID_NAME")]),
    Case("rclpy-declare-type-only", f"{NODE}: TestNode.test_declare_parameter (a type, no value)", "table", {},
         [("declare", "t", None, {"type": "double"}, "ok"), ("has", "t", True), ("get", "t", "INVALID_VALUE"),
          ("set", "t", 1.5, True), ("get", "t", ("double", 1.5))],
         note="rclpy returns an unset Parameter from get_parameter; rclcpp throws. We follow rclcpp."),
    Case("rclpy-declare-no-type-no-value", f"{NODE}: TestNode.test_declare_parameter (no type, no value)",
         "table", {}, [("declare", "x", None, "INVALID_VALUE"), ("has", "x", False)],
         note="rclpy declares it NOT_SET with a deprecation warning; rclcpp refuses a statically typed "
              "parameter without a type. We follow rclcpp."),
    Case("rclpy-declare-dynamic-unset", f"{NODE}: TestNode.test_declare_parameter (dynamic_typing, no value)",
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
    Case("rclpy-static-type-change", f"{NODE}: TestNode.test_static_dynamic_typing", "table", {},
         [("declare", "s", 1, "ok"), ("set", "s", 1.5, False), ("set", "s", "x", False), ("set", "s", 2, True)]),
    Case("rclpy-dynamic-type-change", f"{NODE}: TestNode.test_static_dynamic_typing", "table", {},
         [("declare", "d", 1, {"dynamic_typing": True}, "ok"), ("set", "d", "x", True), ("set", "d", [1, 2], True),
          ("get", "d", ("integer_array", [1, 2]))]),
    Case("rclpy-undeclare", f"{NODE}: TestNode.test_undeclare_parameter", "table", {},
         [("declare", "d", 1, {"dynamic_typing": True}, "ok"), ("undeclare", "d", "ok"),
          ("undeclare", "d", "NOT_FOUND")]),
    Case("rclpy-undeclare-read-only", f"{NODE}: TestNode.test_undeclare_parameter", "table", {},
         [("declare", "r", 1, {"read_only": True, "dynamic_typing": True}, "ok"), ("undeclare", "r", "READ_ONLY")]),
    Case("rclpy-describe-unknown", f"{NODE}: TestNode.test_describe_parameter", "table", {},
         [("describe", "ghost", "NOT_FOUND")]),
    Case("rclpy-describe", f"{NODE}: TestNode.test_describe_parameter", "table", {},
         [("declare", "p", "v", {"description": "words", "additional_constraints": "short"}, "ok"),
          ("describe", "p", {"type": "string", "description": "words", "additional_constraints": "short"})]),
    Case("rclpy-wrong-kind-fp-range-on-string", f"{NODE}: TestNode.test_declare_parameter "
         "(a floating_point_range on a string does not affect it)", "table", {},
         [("declare", "s", "text", {"floating_point_range": (0.0, 1.0, 0.0)}, "ok"), ("set", "s", "more", True)]),
    Case("rclpy-wrong-kind-int-range-on-double", f"{NODE}: TestNode.test_declare_parameter "
         "(an integer_range on a double does not affect it)", "table", {},
         [("declare", "d", 0.5, {"integer_range": (0, 1, 1)}, "ok"), ("set", "d", 9.5, True)]),
    Case("rclpy-byte-array", f"{PARAM}: TestParameter.test_create_byte_array_parameter", "table", {},
         [("declare", "b", b"\x01\xff", "ok"), ("type", "b", "byte_array")]),
    Case("rclpy-bool-array", f"{PARAM}: TestParameter.test_create_bool_array_parameter", "table", {},
         [("declare", "b", [True, False], "ok"), ("get", "b", ("bool_array", [True, False]))]),
    Case("rclpy-string-array", f"{PARAM}: TestParameter.test_create_string_array_parameter", "table", {},
         [("declare", "s", ["a", "b"], "ok"), ("get", "s", ("string_array", ["a", "b"]))]),
    Case("rclpy-double-array", f"{PARAM}: TestParameter.test_create_double_array_parameter", "table", {},
         [("declare", "d", [1.5, 2.5], "ok"), ("get", "d", ("double_array", [1.5, 2.5]))]),
    Case("rclpy-integer-array", f"{PARAM}: TestParameter.test_create_integer_array_parameter", "table", {},
         [("declare", "i", [1, 2], "ok"), ("get", "i", ("integer_array", [1, 2]))]),
    Case("rclpy-bool-is-not-int", f"{PARAM}: TestParameter.test_create_boolean_parameter", "table", {},
         [("declare", "b", True, "ok"), ("type", "b", "bool"), ("set", "b", 1, False)]),
]
