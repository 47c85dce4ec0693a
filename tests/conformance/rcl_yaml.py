"""rcl's C YAML parser as the oracle for parameter files.

:func:`rcl_load` gives a file to rcl exactly as a ROS 2 process gets it
(``rclpy.init(args=['--ros-args', '--params-file', F])``, each file in a Context of its own,
which measured 3-6 ms here, so no subprocess is needed) and reads what a node made with
``automatically_declare_parameters_from_overrides=True`` holds. :func:`our_load` runs our
loader for the same node. Both give ``("ok", {name: (type label, value)})`` or
``("fail", where)``: ``FILE`` (the file is refused) or ``NODE`` (rcl read the file, but the
node could not be made from it: rclpy refuses an override without a value).

:func:`random_file` writes small files from tricky pieces: every scalar form rcl types
specially, tags, flow and block lists, empty maps, nested and repeated node keys,
wildcards, names repeated across sections with other types.
"""

from __future__ import annotations

import random
import warnings
from pathlib import Path
from typing import Any

from paramdds.errors import ParamddsError
from paramdds.formats.ros import load_ros_text_full

from .ros_oracle import AUTOMATIC, from_ros, ros_missing, same_payload

__all__ = ["NODES", "our_load", "random_file", "rcl_load", "ros_missing"]

NODES = ("/robot", "/ns/robot")  # the nodes a generated file is read for


def rcl_load(path: Path, fqns: tuple[str, ...]) -> dict[str, tuple[str, Any]]:
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    context = Context()
    try:
        rclpy.init(args=["--ros-args", "--params-file", str(path)], context=context)
    except Exception:  # RCLError: rcl could not parse the file
        return dict.fromkeys(fqns, ("fail", "FILE"))
    out: dict[str, tuple[str, Any]] = {}
    try:
        for fqn in fqns:
            ns, _, name = fqn.rpartition("/")
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    node = Node(
                        name,
                        namespace=ns or "/",
                        context=context,
                        automatically_declare_parameters_from_overrides=True,
                        start_parameter_services=False,
                        enable_rosout=False,
                    )
            except Exception:
                out[fqn] = ("fail", "NODE")
                continue
            try:
                given = set(node._parameter_overrides)
                out[fqn] = (
                    "ok",
                    {
                        n: from_ros(p)
                        for n, p in node._parameters.items()
                        if n not in AUTOMATIC or n in given
                    },
                )
            finally:
                node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    return out


def our_load(text: str, fqns: tuple[str, ...]) -> dict[str, tuple[str, Any]]:
    out: dict[str, tuple[str, Any]] = {}
    for fqn in fqns:
        try:
            loaded = load_ros_text_full(text, fqn.lstrip("/"), source="oracle.yaml")
        except ParamddsError:
            out[fqn] = ("fail", "FILE")
            continue
        out[fqn] = ("ok", {n: (v.type.label, v.value) for n, v, _ in loaded})
    return out


# --- generating ------------------------------------------------------------------------------

SCALARS = (
    "1", "-7", "+5", "0x1A", "010", "08", "1e3", ".5", "5.", "1.0e-10", ".inf", "-.inf", ".nan",
    "-.nan", "inf", "NaN", "1e-310", "1e-300", "1e999", "9223372036854775807", "9223372036854775808",
    "-9223372036854775809", "yes", "on", "Y", "n", "OFF", "True", "~", "null", "abc", "héllo",
    "'quoted'", '"1"', "''", "1:20", "1_000", "0b101", "2024-01-01", "!!str 1", "!!float 1",
    "!custom abc", "!!int '7'", "$(var tf_prefix)x",
)
LISTS = (
    "[1, 2]", "[1, 2.5]", "[1.0, 2.5]", "[a, 'b']", "[true, no]", "[]", "[.nan, 1.5]", "!foo [1, 2]",
    "\n{i}  - 1\n{i}  - 2", "\n{i}  - x\n{i}  - 1",
)
NAMES = ("a", "b", "c.d", "use_sim_time")
NODE_KEYS = ("robot", "/robot", "/**", "/*", "/ns/robot", "/ns/*", "/**/robot", "ns:robot", "/:robot")


def _value(rng: random.Random, indent: str) -> str:
    r = rng.random()
    if r < 0.65:
        return " " + rng.choice(SCALARS)
    if r < 0.9:
        v = rng.choice(LISTS)
        return v.format(i=indent) if v.startswith("\n") else " " + v
    if r < 0.95:
        return " {}"
    return f"\n{indent}  x: {rng.choice(SCALARS)}\n{indent}  y: {{}}"


def _params(rng: random.Random, indent: str) -> list[str]:
    lines: list[str] = []
    names = rng.sample(NAMES, rng.randint(0, 3))
    for name in names:
        if "." in name and rng.random() < 0.5:  # nested form of a dotted name
            head, tail = name.split(".", 1)
            lines.append(f"{indent}{head}:")
            lines.append(f"{indent}  {tail}:{_value(rng, indent + '  ')}")
        else:
            lines.append(f"{indent}{name}:{_value(rng, indent)}")
    return lines


def random_file(rng: random.Random) -> str:
    lines: list[str] = []
    for _ in range(rng.randint(1, 3)):
        key = rng.choice(NODE_KEYS)
        if ":" in key:  # a nested node key
            outer, inner = key.split(":")
            lines += [f"{outer}:", f"  {inner}:"]
            indent = "    "
        else:
            lines.append(f"{key}:")
            indent = "  "
        body = _params(rng, indent + "  ")
        if not body and rng.random() < 0.5:
            lines.append(f"{indent}ros__parameters: {{}}")
        else:
            lines.append(f"{indent}ros__parameters:")
            lines += body
    return "\n".join(lines) + "\n"


# --- the differences we keep -----------------------------------------------------------------

SUBNORMAL = "a subnormal double in a parameter file (`1e-310`) is a double"
EMPTY_MAP = "an empty map `{}` as a parameter value is refused"
EMPTY_LIST = "an untagged `[]` needs a descriptor or a tag"
_TINY = 2.2250738585072014e-308  # the smallest normal double


def _empty_value(text: str) -> str | None:
    """Which empty value the file gives a parameter (an untagged ``[]`` or a ``{}``), if any."""
    for line in text.splitlines():
        key, sep, rest = line.partition(":")
        if not sep or key.strip() == "ros__parameters":
            continue
        if rest.strip() == "{}":
            return EMPTY_MAP
        if rest.strip() == "[]":
            return EMPTY_LIST
    return None


def _subnormal_only(ros: tuple[str, Any], ours: tuple[str, Any]) -> bool:
    if ros[0] != "ok" or ours[0] != "ok" or ros[1].keys() != ours[1].keys():
        return False
    for name, r in ros[1].items():
        o = ours[1][name]
        if same_payload(r, o):
            continue
        if not (r[0] == "string" and o[0] == "double" and 0 < abs(o[1]) < _TINY and float(r[1]) == o[1]):
            return False
    return True


def explain(text: str, ros: tuple[str, Any], ours: tuple[str, Any]) -> str | None:
    """The Fixed-list sentence that explains a disagreement on one node, or None."""
    empty = _empty_value(text)
    if empty is not None and ours == ("fail", "FILE"):
        return empty
    if _subnormal_only(ros, ours):
        return SUBNORMAL
    return None


DIFFERENCES = (SUBNORMAL, EMPTY_MAP, EMPTY_LIST)


def node_names(text: str) -> tuple[str, ...]:
    """Concrete nodes a real file configures: each node key, its wildcards filled in."""
    import yaml

    out: dict[str, None] = {}

    def walk(node: Any, path: list[str]) -> None:
        if not isinstance(node, yaml.MappingNode):
            return
        for k, v in node.value:
            if k.value == "ros__parameters":
                key = "/" + "/".join(p.strip("/") for p in path if p.strip("/"))
                for fqn in (key.replace("/**", "") or "/robot", key.replace("/**", "/x")):
                    fqn = fqn.replace("/*", "/x")
                    out[fqn if fqn.count("/") > 0 and fqn != "/" else "/robot"] = None
            else:
                walk(v, [*path, str(k.value)])

    walk(yaml.compose(text), [])
    return tuple(out)
