"""The pure core of paramdds: values, descriptors, validation and the parameter table.

Nothing here imports DDS; the DDS layer maps samples to these calls and back.
Names are loaded on first use: a client needs the values, not the table.
"""

from typing import TYPE_CHECKING

from .._lazy import loader

if TYPE_CHECKING:
    from .custom_validators import register_validator
    from .descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
    from .results import (
        ChangeKind,
        ChangeSet,
        GetResult,
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
                "ListResult",
                "ParameterChange",
                "SetOutcome",
                "SetResult",
                "SetVeto",
            ],
            f"{__name__}.results",
        ),
        "ParameterTable": f"{__name__}.table",
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
    "IntegerRange",
    "ListResult",
    "Parameter",
    "ParameterChange",
    "ParameterDescriptor",
    "ParameterTable",
    "ParameterType",
    "ParameterValue",
    "SetOutcome",
    "SetResult",
    "SetVeto",
    "Validator",
    "register_validator",
]
