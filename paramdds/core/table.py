"""CONTRACT STUB — the helper building the core replaces the bodies, keeping every
public name and signature (extending is fine). The DDS layer codes against this.

The parameter table of one node.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum

from ..errors import ErrorCode
from .descriptors import ParameterDescriptor
from .values import Parameter, ParameterType, ParameterValue


class ChangeKind(str, Enum):
    NEW = "new"
    CHANGED = "changed"
    DELETED = "deleted"


@dataclass(frozen=True, slots=True)
class ParameterChange:
    kind: ChangeKind
    name: str
    value: ParameterValue  # NOT_SET for DELETED
    descriptor: ParameterDescriptor


@dataclass(frozen=True, slots=True)
class ChangeSet:
    """What one committed request changed. ``revision`` goes up by one per commit."""

    node_id: str
    revision: int
    changes: tuple[ParameterChange, ...]


@dataclass(frozen=True, slots=True)
class SetResult:
    name: str
    successful: bool
    reason: str = ""  # kept on success too (an on-set callback may say why)
    code: ErrorCode | None = None  # None when successful


@dataclass(frozen=True, slots=True)
class SetOutcome:
    results: tuple[SetResult, ...]
    revision: int  # the node's revision after this request
    change: ChangeSet | None  # None when nothing was committed


@dataclass(frozen=True, slots=True)
class GetResult:
    name: str
    value: ParameterValue | None  # None when not found
    descriptor: ParameterDescriptor | None  # only when asked for, and found
    code: ErrorCode | None = None  # NOT_FOUND / INVALID_NAME
    reason: str = ""


@dataclass(frozen=True, slots=True)
class ListResult:
    names: tuple[str, ...]
    prefixes: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class SetVeto:
    """What an on-set callback returns: ``SetVeto(successful=False, reason=...)``."""

    successful: bool
    reason: str = ""


PreSetCallback = Callable[[list[Parameter]], list[Parameter]]
OnSetCallback = Callable[[list[Parameter]], SetVeto]
PostSetCallback = Callable[[list[Parameter]], None]
ChangeListener = Callable[[ChangeSet], None]


class ParameterTable:
    def __init__(
        self,
        node_id: str,
        *,
        allow_undeclared: bool = False,
        strict_types: bool = False,
        read_only: bool = False,
        use_sim_time: bool = False,
        overrides: Mapping[str, ParameterValue] | None = None,
    ) -> None: ...

    node_id: str
    revision: int

    def declare(
        self,
        name: str,
        default: ParameterValue | object = None,
        descriptor: ParameterDescriptor | None = None,
        *,
        ignore_override: bool = False,
    ) -> ParameterValue: ...
    def undeclare(self, name: str) -> None: ...
    def has(self, name: str) -> bool: ...
    def get(self, name: str) -> ParameterValue: ...
    def describe_one(self, name: str) -> ParameterDescriptor: ...
    def get_many(self, names: Sequence[str], *, with_descriptors: bool = False) -> list[GetResult]: ...
    def get_types(self, names: Sequence[str]) -> list[ParameterType]: ...
    def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome: ...
    def set_atomically(
        self, params: Sequence[Parameter], *, expected_revision: int | None = None
    ) -> SetOutcome: ...
    def list(self, prefixes: Sequence[str] = (), depth: int = 0) -> ListResult: ...
    def names(self) -> list[str]: ...
    def snapshot(self) -> list[tuple[str, ParameterValue, ParameterDescriptor]]: ...
    def __len__(self) -> int: ...
    def add_pre_set_callback(self, cb: PreSetCallback) -> object: ...
    def add_on_set_callback(self, cb: OnSetCallback) -> object: ...
    def add_post_set_callback(self, cb: PostSetCallback) -> object: ...
    def remove_callback(self, handle: object) -> None: ...
    def add_change_listener(self, fn: ChangeListener) -> object: ...
    def remove_change_listener(self, handle: object) -> None: ...
    def declare_from(self, items: Iterable[tuple[str, ParameterValue, ParameterDescriptor | None]]) -> None: ...
