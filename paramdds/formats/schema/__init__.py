"""Autoware's JSON Schema (draft-07) parameter files: declaring a node from one, enforcing it,
checking files offline and deriving a schema from descriptors. No DDS.

One module per job, each depending only on those above it in this list:

* :mod:`.resolve`   reading a schema's JSON documents, draft-07's keywords, following ``$ref``s;
* :mod:`.describe`  mapping its properties to parameters: names, descriptors, defaults;
* :mod:`.enforce`   :class:`NodeSchema`: the violations of a node's values, whole or incremental;
* :mod:`.load`      :func:`load_schema`: a file read, checked, described;
* :mod:`.declare`   :func:`declare_schema`: the parameters declared on a table, the schema
  installed as its whole-node validator;
* :mod:`.check`     parameter files checked offline (against a schema or a spec);
* :mod:`.export`    a schema derived from descriptors.

The names below are loaded on first use: importing this package imports neither
``jsonschema`` nor ``referencing``.
"""

from typing import TYPE_CHECKING

from ..._lazy import loader

if TYPE_CHECKING:
    from .declare import declare_schema
    from .describe import SchemaEntry
    from .enforce import NodeSchema, Violation, to_json
    from .load import load_schema, load_schema_str

__getattr__ = loader(
    __name__,
    {
        "declare_schema": f"{__name__}.declare",
        "SchemaEntry": f"{__name__}.describe",
        **dict.fromkeys(["NodeSchema", "Violation", "to_json"], f"{__name__}.enforce"),
        **dict.fromkeys(["load_schema", "load_schema_str"], f"{__name__}.load"),
    },
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
