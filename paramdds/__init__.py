"""paramdds: ROS 2-grade runtime parameters over seven global keyed DDS topics.

The public API, importable from here::

    from paramdds import ParameterTable, ParameterServer, ParameterClient, make_participant

The pure core (values, descriptors, the table, YAML formats) imports no DDS.
Every name but the errors is loaded on first use, so ``import paramdds`` stays
light, and a command that only needs the client never imports the table.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import core as _core
from ._lazy import loader

if TYPE_CHECKING:
    from .core import (
        NOT_SET,
        ChangeKind,
        ChangeSet,
        FloatingPointRange,
        GetResult,
        HistoryRecord,
        HistoryReply,
        IntegerRange,
        LastChange,
        ListResult,
        Origin,
        Outcome,
        Parameter,
        ParameterChange,
        ParameterDescriptor,
        ParameterTable,
        ParameterType,
        ParameterValue,
        Retention,
        SetOutcome,
        SetResult,
        SetVeto,
        Validator,
        Via,
    )
    from .core.revision import Revision
    from .dds.assign import Assigner
    from .dds.client import AsyncParameterClient, NodeInfo, ParameterClient
    from .dds.monitor import EventKind, MonitorEvent, NodeState, ParameterMonitor
    from .dds.participant import close_participant, make_participant
    from .dds.qos import QosProfiles
    from .dds.server import ParameterServer
    from .secure.identity import load_identity

from .errors import (
    CallTimeoutError,
    ErrorCode,
    ExpiredError,
    FileFormatError,
    InternalError,
    NoHistoryError,
    NotFoundError,
    NotPermittedError,
    NotPersistedError,
    OutcomeUnknownError,
    ParamddsError,
    ParameterError,
    RemoteError,
    TransportError,
    UnavailableError,
)

__getattr__ = loader(
    __name__,
    {
        **dict.fromkeys(_core.__all__, "paramdds.core"),
        "Assigner": "paramdds.dds.assign",
        "Revision": "paramdds.core.revision",
        **dict.fromkeys(["AsyncParameterClient", "NodeInfo", "ParameterClient"], "paramdds.dds.client"),
        **dict.fromkeys(
            ["EventKind", "MonitorEvent", "NodeState", "ParameterMonitor"], "paramdds.dds.monitor"
        ),
        **dict.fromkeys(["close_participant", "make_participant"], "paramdds.dds.participant"),
        "QosProfiles": "paramdds.dds.qos",
        "ParameterServer": "paramdds.dds.server",
        "load_identity": "paramdds.secure.identity",
    },
)

__all__ = [
    "NOT_SET",
    "Assigner",
    "AsyncParameterClient",
    "CallTimeoutError",
    "ChangeKind",
    "ChangeSet",
    "ErrorCode",
    "EventKind",
    "ExpiredError",
    "FileFormatError",
    "FloatingPointRange",
    "GetResult",
    "HistoryRecord",
    "HistoryReply",
    "IntegerRange",
    "InternalError",
    "LastChange",
    "ListResult",
    "MonitorEvent",
    "NoHistoryError",
    "NodeInfo",
    "NodeState",
    "NotFoundError",
    "NotPermittedError",
    "NotPersistedError",
    "Origin",
    "Outcome",
    "OutcomeUnknownError",
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
    "RemoteError",
    "Retention",
    "Revision",
    "SetOutcome",
    "SetResult",
    "SetVeto",
    "TransportError",
    "UnavailableError",
    "Validator",
    "Via",
    "close_participant",
    "load_identity",
    "make_participant",
]
