# ruff: noqa: E501  (data tables: one case per entry reads better than wrapped)
"""Cases from ros2/rclcpp ``rclcpp/test/rclcpp/test_node.cpp`` (our own names and values).

Range cases keep the shape of the upstream descriptor (same spacing of bounds and
step, shifted to our own numbers) so the outcome upstream asserts carries over.
"""

from __future__ import annotations

from .runner import Case

NODE = "ros2/rclcpp rclcpp/test/rclcpp/test_node.cpp"
SET_NA = f"{NODE}: TestNode.set_parameter_undeclared_parameters_not_allowed"
ATOMIC_NA = f"{NODE}: TestNode.set_parameters_atomically_undeclared_parameters_not_allowed"
ATOMIC_A = f"{NODE}: TestNode.set_parameters_atomically_undeclared_parameters_allowed"
SERVICE = "ros2/rclcpp rclcpp/test/rclcpp/test_parameter_service.cpp"


def _ranges() -> list[Case]:
    spec: list[tuple[str, str, tuple[float, float, float], float, list[tuple[float, bool]]]] = [
        ("int-step2", "integer range descriptor", (30, 38, 2), 30,
         [(34, True), (38, True), (35, False), (40, False), (28, False)]),
        ("int-from-gt-to", "integer range descriptor, from_value > to_value", (40, 38, 1), 40,
         [(38, True), (39, False), (30, False), (45, False)]),
        ("int-from-eq-to", "integer range descriptor, from_value = to_value", (38, 38, 1), 38,
         [(38, True), (37, False), (39, False)]),
        ("int-step-over-distance", "integer range descriptor, step > distance(from_value, to_value)",
         (38, 45, 10), 38, [(45, True), (37, False), (39, False), (46, False)]),
        ("int-distance-not-multiple", "integer range descriptor, distance not multiple of the step",
         (38, 48, 7), 38, [(48, True), (45, True), (37, False), (39, False), (52, False)]),
        ("int-step0", "integer range descriptor, step=0", (30, 38, 0), 30,
         [(31, True), (35, True), (38, True), (29, False), (39, False)]),
        ("fp-step", "floating point range descriptor", (20.0, 21.0, 0.25), 20.0,
         [(20.25, True), (21.0, True), (21.3, False), (22.0, False), (19.4, False)]),
        ("fp-negative-step", "floating point range descriptor, negative step", (20.0, 21.0, -0.25), 20.0,
         [(20.25, True), (21.0, True), (21.3, False), (22.0, False), (19.4, False)]),
        ("fp-from-gt-to", "floating point range descriptor, from_value > to_value", (21.0, 20.0, 0.25), 20.0,
         [(21.0, True), (21.25, False), (22.0, False), (19.4, False)]),
        ("fp-from-eq-to", "floating point range descriptor, from_value = to_value", (20.0, 20.0, 0.25), 20.0,
         [(20.0, True), (19.75, False), (20.25, False)]),
    ]
    out = []
    for key, what, rng, default, sets in spec:
        label = "integer" if isinstance(default, int) else "double"
        for v, ok in sets:
            out.append(Case(f"rclcpp-range-{key}-{v}", f"{SET_NA} ({what})", "range",
                            {"type": label, "range": rng, "default": default, "value": v}, ok))
    return out


CASES: list[Case] = [
    *_ranges(),
    Case("rclcpp-range-default-outside", f"{SET_NA} (integer range descriptor and wrong default value)",
         "table", {}, [("declare", "p", 62, {"integer_range": (30, 38, 2)}, "OUT_OF_RANGE"), ("has", "p", False)]),
    Case("rclcpp-set-multiple", f"{SET_NA} (normal use, multiple parameters)", "table", {},
         [("declare", "a", 7, "ok"), ("declare", "b", True, "ok"), ("declare", "c", "text", "ok"),
          ("get", "a", ("integer", 7)), ("set", "b", False, True), ("get", "b", ("bool", False))]),
    Case("rclcpp-set-undeclared-refused", f"{SET_NA} (setting an undeclared parameter throws)", "table", {},
         [("set", "ghost", 3, False), ("has", "ghost", False)]),
    Case("rclcpp-set-wrong-type-static", f"{SET_NA} (statically typed parameter, other type)", "table", {},
         [("declare", "a", 7, "ok"), ("set", "a", "word", False), ("get", "a", ("integer", 7))]),
    Case("rclcpp-notset-unset-dynamic-stays", f"{SET_NA} (PARAMETER_NOT_SET when already not set)", "table", {},
         [("declare", "d", None, {"dynamic_typing": True}, "ok"), ("set", "d", None, True), ("has", "d", True),
          ("type", "d", "not_set")]),
    Case("rclcpp-notset-static-fails", f"{SET_NA} (PARAMETER_NOT_SET on another type fails)", "table", {},
         [("declare", "s", 5, "ok"), ("set", "s", None, False), ("has", "s", True)]),
    Case("rclcpp-notset-dynamic-undeclares", f"{SET_NA} (PARAMETER_NOT_SET with dynamic typing undeclares)",
         "table", {}, [("declare", "d", 5, {"dynamic_typing": True}, "ok"), ("set", "d", None, True),
                       ("has", "d", False)]),
    Case("rclcpp-atomic-normal", f"{ATOMIC_NA} (normal use)", "table", {},
         [("declare", "a", 1, "ok"), ("declare", "b", True, "ok"), ("declare", "c", "blue", "ok"),
          ("atomic", [("a", 2), ("b", False), ("c", "red")], True), ("get", "c", ("string", "red"))]),
    Case("rclcpp-atomic-order", f"{ATOMIC_NA} (overwrite and order of setting)", "table", {},
         [("declare", "a", 1, "ok"), ("atomic", [("a", 42), ("a", 2)], True), ("get", "a", ("integer", 2))]),
    Case("rclcpp-atomic-undeclared-no-change", f"{ATOMIC_NA} (undeclared parameter: nothing changed)", "table",
         {}, [("declare", "a", 1, "ok"), ("declare", "c", 100, "ok"),
              ("atomic", [("a", 2), ("ghost", "x"), ("c", 101)], False),
              ("get", "a", ("integer", 1)), ("get", "c", ("integer", 100)), ("has", "ghost", False)]),
    Case("rclcpp-atomic-notset-unset-dynamic", f"{ATOMIC_NA} (PARAMETER_NOT_SET when already not set)",
         "table", {}, [("declare", "d", None, {"dynamic_typing": True}, "ok"), ("atomic", [("d", None)], True),
                       ("has", "d", True)]),
    Case("rclcpp-atomic-notset-static", f"{ATOMIC_NA} (PARAMETER_NOT_SET on another type fails)", "table", {},
         [("declare", "s", 42, "ok"), ("atomic", [("s", None)], False), ("has", "s", True)]),
    Case("rclcpp-atomic-notset-dynamic", f"{ATOMIC_NA} (PARAMETER_NOT_SET with dynamic typing undeclares)",
         "table", {}, [("declare", "d", 42, {"dynamic_typing": True}, "ok"), ("atomic", [("d", None)], True),
                       ("has", "d", False)]),
    Case("rclcpp-atomic-allowed-implicit", f"{ATOMIC_A} (setting an undeclared parameter declares it)",
         "table", {"options": {"allow_undeclared": True}},
         [("atomic", [("n1", 42), ("n2", "test")], True), ("get", "n1", ("integer", 42)),
          ("get", "n2", ("string", "test"))]),
    Case("rclcpp-atomic-allowed-failure-keeps-undeclared", f"{ATOMIC_A} (a later failure leaves it undeclared)",
         "table", {"options": {"allow_undeclared": True}},
         [("declare", "a", 42, "ok"), ("declare", "c", "test", {"read_only": True}, "ok"),
          ("atomic", [("a", 43), ("b", True), ("c", "other")], False), ("get", "a", ("integer", 42)),
          ("has", "b", False)]),
    Case("rclcpp-set-allowed-implicit", f"{NODE}: TestNode.set_parameter_undeclared_parameters_allowed",
         "table", {"options": {"allow_undeclared": True}},
         [("set", "n1", 42, True), ("get", "n1", ("integer", 42)), ("set", "n1", "str", True),
          ("get", "n1", ("string", "str"))]),
    Case("rclcpp-set-many-allowed", f"{NODE}: TestNode.set_parameters_undeclared_parameters_allowed", "table",
         {"options": {"allow_undeclared": True}},
         [("declare", "a", 42, "ok"), ("set_many", [("a", 43), ("b", "other")], [True, True]),
          ("get", "a", ("integer", 43)), ("get", "b", ("string", "other"))]),
    Case("rclcpp-set-many-not-allowed", f"{NODE}: TestNode.set_parameters_undeclared_parameters_not_allowed",
         "table", {}, [("declare", "a", 1, "ok"), ("set_many", [("a", 2), ("ghost", 3)], [True, False]),
                       ("get", "a", ("integer", 2)), ("has", "ghost", False)]),
    Case("rclcpp-get-declared", f"{NODE}: TestNode.get_parameter_undeclared_parameters_not_allowed", "table", {},
         [("declare", "g", 42, "ok"), ("get", "g", ("integer", 42))]),
    Case("rclcpp-get-undeclared-throws", f"{NODE}: TestNode.get_parameter_undeclared_parameters_not_allowed",
         "table", {}, [("get", "ghost", "NOT_FOUND")]),
    Case("rclcpp-get-undeclared-allowed", f"{NODE}: TestNode.get_parameter_undeclared_parameters_allowed",
         "table", {"options": {"allow_undeclared": True}}, [("get", "ghost", ("not_set", None))],
         deliberate="get and describe report a status per name instead of an empty reply",
         ours=[("get", "ghost", "NOT_FOUND"), ("type", "ghost", "not_set")]),
    Case("rclcpp-declare-default", f"{NODE}: TestNode.declare_parameter_with_no_initial_values", "table", {},
         [("declare", "x", 5, "ok"), ("get", "x", ("integer", 5)), ("has", "x", True)]),
    Case("rclcpp-declare-twice", f"{NODE}: TestNode.declare_parameter_with_no_initial_values", "table", {},
         [("declare", "x", 5, "ok"), ("declare", "x", 6, "ALREADY_DECLARED"), ("get", "x", ("integer", 5))]),
    Case("rclcpp-declare-empty-name", f"{NODE}: TestNode.declare_parameter_with_no_initial_values", "table", {},
         [("declare", "", 5, "INVALID_NAME")]),
    Case("rclcpp-declare-override", f"{NODE}: TestNode.declare_parameter_with_overrides", "table",
         {"overrides": {"x": 43}}, [("declare", "x", 42, "ok"), ("get", "x", ("integer", 43))]),
    Case("rclcpp-declare-override-wrong-type", f"{NODE}: TestNode.declare_parameter_with_overrides "
         "(default type and initial value type do not match)", "table",
         {"overrides": {"x": "text"}}, [("declare", "x", 42, "TYPE_MISMATCH"), ("has", "x", False)]),
    Case("rclcpp-declare-override-out-of-range", f"{SET_NA} (integer range descriptor and wrong default value)", "table",
         {"overrides": {"x": 99}}, [("declare", "x", 1, {"integer_range": (0, 10, 1)}, "OUT_OF_RANGE")]),
    Case("rclcpp-declare-type-no-value", f"{NODE}: TestNode.static_and_dynamic_typing "
         "(integer_override_not_given, integer_set_after_declare)", "table", {},
         [("declare", "t", None, {"type": "integer"}, "ok"), ("has", "t", True), ("get", "t", "INVALID_VALUE"),
          ("describe", "t", {"type": "integer"}), ("set", "t", 4, True), ("get", "t", ("integer", 4))]),
    Case("rclcpp-declare-type-no-value-override", f"{NODE}: TestNode.static_and_dynamic_typing "
         "(integer_must_provide_override)", "table", {"overrides": {"t": 8}},
         [("declare", "t", None, {"type": "integer"}, "ok"), ("get", "t", ("integer", 8))]),
    Case("rclcpp-declare-type-no-value-wrong-set", f"{NODE}: TestNode.static_and_dynamic_typing "
         "(a statically typed parameter without a value keeps its type)", "table", {},
         [("declare", "t", None, {"type": "string"}, "ok"), ("set", "t", 3, False), ("set", "t", "s", True)]),
    Case("rclcpp-static-vs-dynamic", f"{NODE}: TestNode.static_and_dynamic_typing", "table", {},
         [("declare", "s", 1, "ok"), ("set", "s", "x", False), ("declare", "d", 1, {"dynamic_typing": True}, "ok"),
          ("set", "d", "x", True), ("get", "d", ("string", "x"))]),
    Case("rclcpp-undeclare", f"{NODE}: TestNode.undeclare_parameter", "table", {},
         [("declare", "d", 1, {"dynamic_typing": True}, "ok"), ("undeclare", "d", "ok"), ("has", "d", False)]),
    Case("rclcpp-undeclare-unknown", f"{NODE}: TestNode.undeclare_parameter", "table", {},
         [("undeclare", "ghost", "NOT_FOUND")]),
    Case("rclcpp-undeclare-read-only", f"{NODE}: TestNode.undeclare_parameter (read only parameter throws)", "table", {},
         [("declare", "r", 42, {"read_only": True}, "ok"), ("undeclare", "r", "READ_ONLY"), ("has", "r", True)]),
    Case("rclcpp-undeclare-static", f"{NODE}: TestNode.undeclare_parameter (statically typed)", "table", {},
         [("declare", "s", 1, "ok"), ("undeclare", "s", "TYPE_MISMATCH"), ("has", "s", True)]),
    Case("rclcpp-read-only-described", f"{NODE}: TestNode.declare_parameter_with_no_initial_values "
         "(int default, no initial, custom parameter descriptor)", "table", {},
         [("declare", "r", 42, {"read_only": True}, "ok"), ("get", "r", ("integer", 42)),
          ("describe", "r", {"read_only": True})]),
    Case("rclcpp-has", f"{NODE}: TestNode.has_parameter", "table", {},
         [("has", "h", False), ("declare", "h", 1, "ok"), ("has", "h", True)]),
    Case("rclcpp-describe-undeclared", f"{NODE}: TestNode.describe_parameter_undeclared_parameters_not_allowed",
         "table", {}, [("describe", "ghost", "NOT_FOUND")]),
    Case("rclcpp-describe", f"{NODE}: TestNode.describe_parameter_undeclared_parameters_not_allowed", "table", {},
         [("declare", "p", 4.5, {"description": "speed", "read_only": True}, "ok"),
          ("describe", "p", {"name": "p", "type": "double", "description": "speed", "read_only": True})]),
    Case("rclcpp-get-types", f"{NODE}: TestNode.get_parameter_types_undeclared_parameters_not_allowed", "table",
         {}, [("declare", "i", 1, "ok"), ("declare", "s", "x", "ok"), ("type", "i", "integer"),
              ("type", "s", "string")]),
    Case("rclcpp-list-prefixes", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: "
         "NodeParameters::list_parameters (a prefix lists its names and itself as a prefix)", "table",
         {}, [("declare", "grp.a", 1, "ok"), ("declare", "grp.b", 2, "ok"), ("declare", "top", 3, "ok"),
              ("list", ["grp"], 0, (["grp.a", "grp.b"], ["grp"]))]),
    Case("rclcpp-list-all", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: "
         "NodeParameters::list_parameters (no prefix, recursive depth)", "table", {},
         [("declare", "grp.a", 1, "ok"), ("declare", "top", 3, "ok"),
          ("list", [], 0, (["grp.a", "top"], ["grp"]))]),
    Case("rclcpp-wrong-kind-fp-range-on-int", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: __check_parameter_value_in_range (a range applies only to a value of its type)",
         "table", {}, [("declare", "i", 50, {"floating_point_range": (0.0, 1.0, 0.0)}, "ok"), ("set", "i", 99, True)]),
    Case("rclcpp-wrong-kind-int-range-on-string", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: __check_parameter_value_in_range (a range applies only to a value of its type)",
         "table", {}, [("declare", "s", "x", {"integer_range": (0, 1, 1)}, "ok"), ("set", "s", "y", True)]),
    Case("rclcpp-wrong-kind-int-range-on-double", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: __check_parameter_value_in_range (a range applies only to a value of its type)",
         "table", {}, [("declare", "d", 5.5, {"integer_range": (0, 1, 1)}, "ok"), ("set", "d", 7.5, True)]),
    Case("rclcpp-wrong-kind-fp-range-on-string", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: __check_parameter_value_in_range (a range applies only to a value of its type)",
         "table", {}, [("declare", "s", "x", {"floating_point_range": (0.0, 1.0, 0.0)}, "ok"),
                       ("set", "s", "z", True)]),
    Case("rclcpp-range-on-array-elements", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/node_parameters.cpp: "
         "__check_parameter_value_in_range (ranges apply to integer and double scalars only)", "table", {},
         [("declare", "a", [1, 2], {"integer_range": (0, 10, 1)}, "ok"), ("set", "a", [1, 20], True)],
         deliberate="a range also bounds each element of an integer or double array",
         ours=[("declare", "a", [1, 2], {"integer_range": (0, 10, 1)}, "ok"), ("set", "a", [1, 20], False),
               ("get", "a", ("integer_array", [1, 2]))]),
    Case("rclcpp-descriptor-type-contradicts-value", "ros2/rclcpp rclcpp/src/rclcpp/node_interfaces/"
         "node_parameters.cpp: declare_parameter_helper (descriptor.type is overwritten by the value's type)",
         "table", {}, [("declare", "x", 5, {"type": "string"}, "ok"), ("get", "x", ("integer", 5)),
                       ("describe", "x", {"type": "integer"})]),
    Case("rclcpp-override-ignored", f"{NODE}: TestNode.declare_parameter_with_overrides "
         "(int default, with override and ignoring it)", "table", {"overrides": {"x": 42}},
         [("declare_ignoring_override", "x", 43, "ok"), ("get", "x", ("integer", 43))]),
    Case("rclcpp-override-read-only", f"{NODE}: TestNode.declare_parameter_with_overrides "
         "(int default, with initial, custom parameter descriptor)", "table", {"overrides": {"x": 42}},
         [("declare", "x", 43, {"read_only": True}, "ok"), ("get", "x", ("integer", 42)),
          ("describe", "x", {"read_only": True})]),
    Case("rclcpp-static-override-wrong-type", f"{NODE}: TestNode.static_and_dynamic_typing "
         "(string_parameter_override_should_throw)", "table", {"overrides": {"s": 43}},
         [("declare", "s", "a string", "TYPE_MISMATCH"), ("has", "s", False)]),
    Case("rclcpp-static-override-ok", f"{NODE}: TestNode.static_and_dynamic_typing (integer_parameter_override_ok)",
         "table", {"overrides": {"i": 43}}, [("declare", "i", 42, "ok"), ("get", "i", ("integer", 43))]),
    Case("rclcpp-type-and-dynamic-typing", f"{NODE}: TestNode.declare_parameter_with_overrides "
         "(cannot pass an expected type and a descriptor with dynamic_typing=True)", "table", {},
         [("declare", "t", None, {"type": "integer", "dynamic_typing": True}, "INVALID_VALUE")]),
    Case("rclcpp-allow-undeclared-static-kept", f"{NODE}: TestNode.declare_parameter_with_allow_undeclared_parameters "
         "(declared parameters static typing is still enforced)", "table", {"options": {"allow_undeclared": True}},
         [("declare", "p", 5, "ok"), ("set", "p", "asd", False), ("get", "p", ("integer", 5))]),
    Case("rclcpp-allow-undeclared-implicit-dynamic", f"{NODE}: TestNode.declare_parameter_with_allow_undeclared_parameters "
         "(not for automatically declared parameters)", "table", {"options": {"allow_undeclared": True}},
         [("set", "p", 5, True), ("set", "p", "asd", True), ("get", "p", ("string", "asd"))]),
    Case("rclcpp-allow-undeclared-declare-after-set", f"{NODE}: TestNode.declare_parameter_with_allow_undeclared_parameters "
         "(declare after set is invalid)", "table", {"options": {"allow_undeclared": True}},
         [("set", "p", 5, True), ("declare", "p", 5, "ALREADY_DECLARED")]),
    Case("rclcpp-declare-parameters-namespace", f"{NODE}: TestNode.declare_parameters_with_no_initial_values "
         "(with namespace: the namespace itself is not a parameter)", "table", {},
         [("declare", "ns1.a", 42, "ok"), ("declare", "ns1.b", 2**63 - 43, "ok"), ("has", "ns1", False),
          ("get", "ns1.b", ("integer", 2**63 - 43))]),
    Case("rclcpp-list-after-undeclare", f"{NODE}: TestNode.list_parameters", "table", {},
         [("declare", "d", None, {"dynamic_typing": True}, "ok"), ("list", [], 1, (["d"], [])),
          ("undeclare", "d", "ok"), ("list", [], 1, ([], []))]),
    Case("rclcpp-get-types-undeclared-node-level", f"{NODE}: TestNode.get_parameter_types_undeclared_parameters_allowed "
         "(undeclared names are NOT_SET, same order as input)", "table", {"options": {"allow_undeclared": True}},
         [("type", "ghost", "not_set")]),
    Case("rclcpp-node-parameters-list", "ros2/rclcpp rclcpp/test/rclcpp/node_interfaces/test_node_parameters.cpp: "
         "TestNodeParameters.list_parameters", "table", {},
         [("list", [], 1, ([], [])), ("declare", "new_parameter", True, "ok"), ("list", [], 1, (["new_parameter"], []))]),
    Case("rclcpp-service-get", f"{SERVICE}: TestParameterService.get_parameters", "table", {},
         [("declare", "p1", 42, "ok"), ("get", "p1", ("integer", 42)), ("get", "undeclared", "NOT_FOUND")]),
    Case("rclcpp-service-get-types", f"{SERVICE}: TestParameterService.get_parameter_types", "table", {},
         [("declare", "p1", 42, "ok"), ("type", "p1", "integer"), ("get_types", ["p2"], [])],
         deliberate="get and describe report a status per name instead of an empty reply",
         ours=[("declare", "p1", 42, "ok"), ("type", "p1", "integer"), ("get_types", ["p2"], ["not_set"])]),
    Case("rclcpp-service-set", f"{SERVICE}: TestParameterService.set_parameters", "table", {},
         [("declare", "p1", 42, "ok"), ("set", "p1", 0, True), ("get", "p1", ("integer", 0))]),
    Case("rclcpp-service-set-atomically", f"{SERVICE}: TestParameterService.set_parameters_atomically", "table", {},
         [("declare", "p1", 42, "ok"), ("atomic", [("p1", 0)], True), ("get", "p1", ("integer", 0))]),
    Case("rclcpp-service-list", f"{SERVICE}: TestParameterService.list_parameters", "table", {},
         [("declare", "p1", 42, "ok"), ("list", [], 1, (["p1"], []))]),
    Case("rclcpp-service-describe", f"{SERVICE}: TestParameterService.describe_parameters", "table", {},
         [("declare", "p1", 42, "ok"), ("describe", "p1", {"name": "p1", "type": "integer"}),
          ("describe", "undeclared", "NOT_FOUND")]),
    Case("rclcpp-service-descriptor", f"{SERVICE}: TestParameterService.parameter_descriptor", "table", {},
         [("declare", "int_parameter", 1, {"description": "description", "additional_constraints": "constraints",
                                           "integer_range": (0, 10, 1)}, "ok"),
          ("describe", "int_parameter", {"type": "integer", "description": "description",
                                         "additional_constraints": "constraints", "read_only": False,
                                         "dynamic_typing": False}),
          ("get", "int_parameter", ("integer", 1))]),
    Case("rclcpp-int-for-double-widened", f"{NODE}: (rclcpp#979: an integer for a double parameter)", "table",
         {}, [("declare", "d", 1.5, "ok"), ("set", "d", 2, False)],
         deliberate="an integer for a double parameter is widened (`50` → `50.0`, rclcpp#979) unless strict",
         ours=[("declare", "d", 1.5, "ok"), ("set", "d", 2, True), ("get", "d", ("double", 2.0))]),
]
