"""paramdds: ROS 2-grade runtime parameters over seven global keyed DDS topics.

The public API, importable from here::

    from paramdds import ParameterTable, ParameterServer, ParameterClient, make_participant

The pure core (values, descriptors, the table, YAML formats) imports no DDS.
The DDS names (server, client, monitor, assigner, participant) are loaded on
first use, so ``import paramdds`` stays light for tools that never touch DDS.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .core import (
    NOT_SET,
    ChangeKind,
    ChangeSet,
    FloatingPointRange,
    GetResult,
    IntegerRange,
    ListResult,
    Parameter,
    ParameterChange,
    ParameterDescriptor,
    ParameterTable,
    ParameterType,
    ParameterValue,
    SetOutcome,
    SetResult,
    SetVeto,
    Validator,
)
from .errors import (
    ErrorCode,
    FileFormatError,
    NotFoundError,
    ParamddsError,
    ParameterError,
    TimeoutError_,
    TransportError,
    UnavailableError,
)

if TYPE_CHECKING:
    from .dds.assign import Assigner
    from .dds.client import AsyncParameterClient, NodeInfo, ParameterClient
    from .dds.monitor import EventKind, MonitorEvent, NodeState, ParameterMonitor
    from .dds.participant import close_participant, make_participant
    from .dds.qos import QosProfiles
    from .dds.server import ParameterServer

_LAZY = {
    "Assigner": "paramdds.dds.assign",
    "AsyncParameterClient": "paramdds.dds.client",
    "NodeInfo": "paramdds.dds.client",
    "ParameterClient": "paramdds.dds.client",
    "EventKind": "paramdds.dds.monitor",
    "MonitorEvent": "paramdds.dds.monitor",
    "NodeState": "paramdds.dds.monitor",
    "ParameterMonitor": "paramdds.dds.monitor",
    "close_participant": "paramdds.dds.participant",
    "make_participant": "paramdds.dds.participant",
    "QosProfiles": "paramdds.dds.qos",
    "ParameterServer": "paramdds.dds.server",
}

__all__ = [
    "NOT_SET",
    "Assigner",
    "AsyncParameterClient",
    "ChangeKind",
    "ChangeSet",
    "ErrorCode",
    "EventKind",
    "FileFormatError",
    "FloatingPointRange",
    "GetResult",
    "IntegerRange",
    "ListResult",
    "MonitorEvent",
    "NodeInfo",
    "NodeState",
    "NotFoundError",
    "ParamddsError",
    "Parameter",
    "ParameterChange",
    "ParameterClient",
    "ParameterDescriptor",
    "ParameterError",
    "ParameterMonitor",
    "ParameterServer",
    "ParameterTable",
    "ParameterType",
    "ParameterValue",
    "QosProfiles",
    "SetOutcome",
    "SetResult",
    "SetVeto",
    "TimeoutError_",
    "TransportError",
    "UnavailableError",
    "Validator",
    "close_participant",
    "make_participant",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'paramdds' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
