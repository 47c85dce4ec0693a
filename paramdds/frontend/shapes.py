"""What the front ends print and serve beyond values and descriptors: a node's shown id, JSON text.

Values and descriptors become JSON in :mod:`paramdds.core.jsonform` (its bare form is the
one the CLI prints and the console serves). Pure functions; no DDS here.
"""

from __future__ import annotations

import json


def shown_node(node: str, origin: str | None) -> str:
    """A node id as an operator knows it: a ROS 2 node (mirrored by the bridge, origin
    ``ros2``) with its leading slash (``/arm/driver``), a paramdds node without
    (``robot1``). Both forms are accepted wherever a node is given."""
    return "/" + node if origin == "ros2" else node


def dumps_json(obj: object, *, pretty: bool = True) -> str:
    """JSON text; refuses NaN (values must go through :func:`paramdds.core.jsonform.json_value` first)."""
    return json.dumps(obj, indent=2 if pretty else None, ensure_ascii=False, allow_nan=False)
