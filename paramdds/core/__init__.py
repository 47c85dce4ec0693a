"""The pure core of paramdds: values, descriptors, validation and the parameter table.

Nothing here imports DDS; the DDS layer maps samples to these calls and back.
Names are loaded on first use: a client needs the values, not the table.
"""

from typing import TYPE_CHECKING

from .._lazy import loader

if TYPE_CHECKING:
    from .custom_validators import register_validator
    from .descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
    from .history import HistoryRecord, Outcome, Retention
    from .origin import Origin, Via
    from .replies import HistoryReply
    from .results import (
        ChangeKind,
        ChangeSet,
        GetResult,
        LastChange,
        ListResult,
        ParameterChange,
        SetOutcome,
        SetResult,
        SetVeto,
    )
    from .table import ParameterTable
    from .values import NOT_SET, Parameter, ParameterType, ParameterValue

__getattr__ = loader(
    __name__,
    {
        **dict.fromkeys(
            ["FloatingPointRange", "IntegerRange", "ParameterDescriptor", "Validator"],
            f"{__name__}.descriptors",
        ),
        **dict.fromkeys(
            [
                "ChangeKind",
                "ChangeSet",
                "GetResult",
                "LastChange",
                "ListResult",
                "ParameterChange",
                "SetOutcome",
                "SetResult",
                "SetVeto",
            ],
            f"{__name__}.results",
        ),
        "ParameterTable": f"{__name__}.table",
        **dict.fromkeys(["HistoryRecord", "Outcome", "Retention"], f"{__name__}.history"),
        **dict.fromkeys(["Origin", "Via"], f"{__name__}.origin"),
        "HistoryReply": f"{__name__}.replies",
        "register_validator": f"{__name__}.custom_validators",
        **dict.fromkeys(["NOT_SET", "Parameter", "ParameterType", "ParameterValue"], f"{__name__}.values"),
    },
)

__all__ = [
    "NOT_SET",
    "ChangeKind",
    "ChangeSet",
    "FloatingPointRange",
    "GetResult",
    "HistoryRecord",
    "HistoryReply",
    "IntegerRange",
    "LastChange",
    "ListResult",
    "Origin",
    "Outcome",
    "Parameter",
    "ParameterChange",
    "ParameterDescriptor",
    "ParameterTable",
    "ParameterType",
    "ParameterValue",
    "Retention",
    "SetOutcome",
    "SetResult",
    "SetVeto",
    "Validator",
    "Via",
    "register_validator",
]
