"""The pure core of paramdds: values, descriptors, validation and the parameter table.

Nothing here imports DDS; the DDS layer maps samples to these calls and back.
"""

from .descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from .table import (
    ChangeKind,
    ChangeSet,
    GetResult,
    ListResult,
    ParameterChange,
    ParameterTable,
    SetOutcome,
    SetResult,
    SetVeto,
)
from .values import NOT_SET, Parameter, ParameterType, ParameterValue

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
]
