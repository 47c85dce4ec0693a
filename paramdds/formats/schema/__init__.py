"""Autoware's JSON Schema (draft-07) parameter files: declaring a node from one, enforcing it,
checking files offline (:mod:`.check`) and deriving a schema from descriptors (:mod:`.export`).

The names below are loaded on first use: importing this package imports neither
``jsonschema`` nor ``referencing``.
"""

from typing import TYPE_CHECKING

from ..._lazy import loader

if TYPE_CHECKING:
    from .enforce import (
        NodeSchema,
        SchemaEntry,
        Violation,
        declare_schema,
        load_schema,
        load_schema_str,
        to_json,
    )

__getattr__ = loader(
    __name__,
    dict.fromkeys(
        [
            "NodeSchema",
            "SchemaEntry",
            "Violation",
            "declare_schema",
            "load_schema",
            "load_schema_str",
            "to_json",
        ],
        f"{__name__}.enforce",
    ),
)

__all__ = [
    "NodeSchema",
    "SchemaEntry",
    "Violation",
    "declare_schema",
    "load_schema",
    "load_schema_str",
    "to_json",
]
