"""The parameter table of one node: declare, get, set, list — ROS 2 semantics, pure Python.

One :class:`ParameterTable` holds the parameters of one node. It knows nothing of
DDS: the DDS layer turns requests into calls here and the :class:`ChangeSet` s this
table emits into samples.

How a set request is applied
    1. **Refusals of the whole request**: a stale ``expected_revision``
       (compare-and-set) fails every parameter with CONFLICT; more than
       ``MAX_PARAMETERS_PER_REQUEST`` parameters fail with TOO_LARGE. Nothing runs.
    2. **Pre-set callbacks** get the list and return a new one (they may change
       values, drop or add parameters).
    3. **Validation** of each parameter: its name (INVALID_NAME), the table's
       ``read_only`` flag and the parameter's (READ_ONLY), its size (TOO_LARGE),
       whether it is declared (NOT_FOUND, unless ``allow_undeclared``), its type
       (TYPE_MISMATCH; an integer widens to a double unless ``strict_types``), its
       range and validators (OUT_OF_RANGE / INVALID_VALUE).
    4. **On-set callbacks** may veto with ``SetVeto(False, reason)``. A reason
       given with ``SetVeto(True, reason)`` is kept in the results.
    5. **Commit**: everything that passed is written under one new revision and
       described by one :class:`ChangeSet`.
    6. **Change listeners** get that ChangeSet.
    7. **Post-set callbacks** get the parameters that were applied.

:meth:`ParameterTable.set` follows rclcpp, whose ``set_parameters`` runs
``set_parameters_atomically`` once per parameter: steps 2-4 run for each
parameter on its own (the pre-set callbacks get a one-element list, the on-set
callbacks get what came out of it), so a veto or an error fails only that
parameter. Unlike rclcpp, everything that passed is then committed together in
one revision, and each parameter is checked against the state left by the ones
before it in the same request. :meth:`ParameterTable.set_atomically` runs steps
2-4 once for the whole list; any failure fails every parameter (the failing ones
say why, the others ``not applied: the atomic set failed on 'x'``). Either way
there is one result per requested parameter, in request order, and a request that
commits nothing changes nothing (same snapshot, same revision).

Callbacks of one kind run in ROS 2 order: the last registered runs first. On-set
and post-set callbacks see the values as they will be stored (an integer already
widened to a double); a deletion is a parameter whose value is ``NOT_SET``.
:meth:`ParameterTable.declare` runs the on-set callbacks (a veto refuses the
declaration) and the post-set callbacks, as rclcpp does; it does not run pre-set
callbacks. :meth:`ParameterTable.undeclare` runs no callbacks (as rclcpp), only
the change listeners.

Callbacks and listeners must not change parameters: ``set``, ``declare``,
``undeclare`` (and adding or removing callbacks) from inside one raise
:class:`~paramdds.errors.CallbackError` (IN_CALLBACK) at once — no deadlock, no
recursion. An exception raised by a pre-set or on-set callback fails the request
with its message, and nothing changes; one raised by a post-set callback or a
change listener (after the commit) is logged, and a post-set failure is added to
the reasons of the results.

Deleting: setting a parameter to ``NOT_SET`` deletes it when it is dynamically
typed (ChangeKind.DELETED); a statically typed one cannot be deleted
(TYPE_MISMATCH), a read-only one cannot be changed at all (READ_ONLY). A dynamically
typed parameter that has no value stays declared when set to ``NOT_SET`` (rclcpp).

Unset parameters: as in rclcpp and rclpy, a statically typed parameter may be
declared with a type and no value. It is listed and described, ``get_many``
reports its value as NOT_SET, ``get`` raises until it is set, and only a value
of its type sets it.

Whole-node validator: :meth:`ParameterTable.set_node_validator` installs one function
that sees the node as a request would leave it (every value, after step 3, before the
on-set callbacks) and the names the request touches with their values before it (None:
absent), and returns ``(name, reason)`` to refuse it (``name`` is the parameter at
fault, ``""`` for all of them) or None.
It runs for every unit of a set (so per parameter for :meth:`ParameterTable.set`, once
for an atomic set), for declarations and for undeclare; a refusal is INVALID_VALUE.
A JSON Schema uses it (:mod:`paramdds.formats.schema`): checks such as ``required`` or
``oneOf`` concern several parameters at once.

Threads: every request runs under one re-entrant lock, so it is applied atomically
with respect to other threads; reads take the same lock. Callbacks and listeners
run under it too, so keep them short.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import replace

from ..errors import (
    AlreadyDeclaredError,
    CallbackError,
    ErrorCode,
    InvalidValueError,
    NotFoundError,
    ParamddsError,
    ReadOnlyError,
    TooLargeError,
    TypeMismatchError,
    error_for,
)
from . import deadline as deadlines
from . import origin as origins
from .descriptors import ParameterDescriptor
from .limits import check_request_size, check_text, check_value
from .listing import list_names
from .names import is_valid_name, validate_name
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
from .validation import check_descriptor, validate
from .values import NOT_SET, Parameter, ParameterType, ParameterValue

log = logging.getLogger(__name__)


PreSetCallback = Callable[[list[Parameter]], list[Parameter]]
OnSetCallback = Callable[[list[Parameter]], SetVeto]
PostSetCallback = Callable[[list[Parameter]], None]
ChangeListener = Callable[[ChangeSet], None]
# (the node's values as the request would leave them, {touched name: its value before or None})
#   -> (name at fault, reason) or None
NodeValidator = Callable[
    [Mapping[str, ParameterValue], Mapping[str, "ParameterValue | None"]], "tuple[str, str] | None"
]

_Entry = tuple[ParameterValue, ParameterDescriptor]


class _Handle:
    """What ``add_*_callback`` returns; pass it to ``remove_callback``."""

    __slots__ = ("fn", "kind")

    def __init__(self, kind: str, fn: Callable[..., object]) -> None:
        self.kind = kind
        self.fn = fn

    def __repr__(self) -> str:
        return f"<{self.kind} callback {getattr(self.fn, '__qualname__', self.fn)!r}>"


class _UnitFailed(Exception):
    """Steps 2-4 refused a unit: ``name`` is the parameter at fault (None: all of them)."""

    def __init__(self, name: str | None, error: ParamddsError) -> None:
        super().__init__(error.message)
        self.name = name
        self.error = error


class _Stage:
    """The table as a request would leave it: pending writes over the committed entries."""

    def __init__(self, base: Mapping[str, _Entry], parent: _Stage | None = None) -> None:
        self.base = base
        self.parent = parent
        self.pending: dict[str, _Entry | None] = {}  # None: deleted; insertion = first touch

    def get(self, name: str) -> _Entry | None:
        if name in self.pending:
            return self.pending[name]
        if self.parent is not None:
            return self.parent.get(name)
        return self.base.get(name)

    def trial(self) -> _Stage:
        """A layer over this stage for one unit; :meth:`keep` it when the unit passes."""
        return _Stage(self.base, self)

    def keep(self) -> None:
        assert self.parent is not None
        self.parent.pending.update(self.pending)

    def before(self, name: str) -> ParameterValue | None:
        """The value of ``name`` without this stage's own writes (None: absent)."""
        entry = self.parent.get(name) if self.parent is not None else self.base.get(name)
        return None if entry is None else entry[0]

    def values(self) -> dict[str, ParameterValue]:
        """Every value as this stage would leave the table."""
        layers = []
        stage: _Stage | None = self
        while stage is not None:
            layers.append(stage.pending)
            stage = stage.parent
        out = {name: entry[0] for name, entry in self.base.items()}
        for pending in reversed(layers):
            for name, entry in pending.items():
                if entry is None:
                    out.pop(name, None)
                else:
                    out[name] = entry[0]
        return out


# Aliases: inside ParameterTable, ``list`` names the method.
_Objects = list[object]
_Params = list[Parameter]
_Results = list[SetResult]
_Handles = list[_Handle]
_Strings = list[str]
_Changes = list[ParameterChange]
_Snapshot = list[tuple[str, ParameterValue, ParameterDescriptor]]


def _text(name: object) -> str:
    return name if isinstance(name, str) else repr(name)[:80]


def _name_of(p: object) -> str:
    return _text(getattr(p, "name", ""))


def _check_names(names: object) -> None:
    if isinstance(names, (str, bytes)) or not isinstance(names, Iterable):
        raise InvalidValueError(f"expected a list of parameter names, got {type(names).__name__}")


def _not_declared(name: str) -> NotFoundError:
    """A set of a name the table does not have, on a table that accepts no new names."""
    return NotFoundError(
        f"parameter {name!r} is not declared (start the node with --allow-undeclared to accept new names)"
    )


def _callback_error(stage: str, exc: Exception) -> ParamddsError:
    if isinstance(exc, ParamddsError):
        return error_for(exc.code, f"{stage} callback failed: {exc.message}")
    return InvalidValueError(f"{stage} callback failed: {type(exc).__name__}: {exc}")


class ParameterTable:
    """The parameters of one node (see the module docstring for the rules)."""

    #: False: its sets commit here (a server hosts it as a :class:`~.hosted.HostedTable`).
    forwards_writes = False

    def __init__(
        self,
        node_id: str,
        *,
        allow_undeclared: bool = False,
        strict_types: bool = False,
        read_only: bool = False,
        use_sim_time: bool = False,
        overrides: Mapping[str, ParameterValue] | None = None,
    ) -> None:
        self.node_id: str = node_id
        self.revision: int = 0
        self.allow_undeclared = allow_undeclared
        self.strict_types = strict_types
        self.read_only = read_only
        self._params: dict[str, _Entry] = {}
        self._sorted: list[str] | None = None
        self._lock = threading.RLock()
        self._local = threading.local()
        self._pre: list[_Handle] = []
        self._on: list[_Handle] = []
        self._post: list[_Handle] = []
        self._listeners: list[_Handle] = []
        self._hooks: list[_Handle] = []
        self._in_hooks = False
        self._node_validator: NodeValidator | None = None
        self._overrides: dict[str, ParameterValue] = {}
        for name, value in (overrides or {}).items():
            v = value if isinstance(value, ParameterValue) else ParameterValue.from_python(value)
            self._overrides[validate_name(name)] = v
        if use_sim_time:
            self.declare("use_sim_time", False)

    # --- reading ---------------------------------------------------------------------------

    @contextmanager
    def try_locked(self) -> Iterator[bool]:
        """Hold the table's lock if it is free right now (yields True), else yield False at once.

        For a caller that must never wait on a callback another thread is running (the
        server's dispatch thread answers reads inline only when this succeeds)."""
        got = self._lock.acquire(blocking=False)
        try:
            yield got
        finally:
            if got:
                self._lock.release()

    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the table's lock: no commit, nor the change listeners it calls, runs meanwhile
        (a store that snapshots the table and takes what its listeners queued, as one)."""
        with self._lock:
            yield

    def has(self, name: str) -> bool:
        with self._lock:
            return isinstance(name, str) and name in self._params

    def get(self, name: str) -> ParameterValue:
        """The value of ``name``; NotFoundError when it is not declared.

        A statically typed parameter declared without a value raises InvalidValueError until
        it is set (rclcpp's ParameterUninitializedException); ``get_many`` reports it as NOT_SET.
        """
        value, desc = self._entry(name)
        if value.type is ParameterType.NOT_SET and not desc.dynamic_typing:
            raise InvalidValueError(
                f"parameter {name!r} is declared ({desc.type.label}) but has no value yet; set it first"
            )
        return value

    def has_override(self, name: str) -> bool:
        """Whether the table was given an override (a parameter-file value) for ``name``."""
        return name in self._overrides

    def override(self, name: str) -> ParameterValue | None:
        """The override (a parameter-file value) given for ``name``, or None."""
        return self._overrides.get(name)

    def describe_one(self, name: str) -> ParameterDescriptor:
        """The descriptor of ``name``; NotFoundError when it is not declared."""
        return self._entry(name)[1]

    def _entry(self, name: str) -> _Entry:
        with self._lock:
            entry = self._params.get(name) if isinstance(name, str) else None
        if entry is None:
            validate_name(name)
            raise NotFoundError(f"parameter {name!r} is not declared on node {self.node_id!r}")
        return entry

    def get_many(self, names: Sequence[str], *, with_descriptors: bool = False) -> list[GetResult]:
        """One result per name, in order: a value, or a NOT_FOUND / INVALID_NAME status."""
        _check_names(names)
        out: list[GetResult] = []
        with self._lock:
            for name in names:
                entry = self._params.get(name) if isinstance(name, str) else None
                if entry is not None:
                    out.append(GetResult(name, entry[0], entry[1] if with_descriptors else None))
                elif not is_valid_name(name):
                    try:
                        validate_name(name)
                        reason = f"invalid parameter name {name!r}"  # pragma: no cover
                    except ParamddsError as exc:
                        reason = exc.message
                    out.append(GetResult(_text(name), None, None, ErrorCode.INVALID_NAME, reason))
                else:
                    reason = f"parameter {name!r} is not declared on node {self.node_id!r}"
                    out.append(GetResult(name, None, None, ErrorCode.NOT_FOUND, reason))
        return out

    def get_types(self, names: Sequence[str]) -> list[ParameterType]:
        """The type of each name; NOT_SET for an unknown one (as ROS 2 does)."""
        _check_names(names)
        with self._lock:
            return [
                self._params[n][0].type if isinstance(n, str) and n in self._params else ParameterType.NOT_SET
                for n in names
            ]

    def list(self, prefixes: Sequence[str] = (), depth: int = 0) -> ListResult:
        """Names and prefixes by rclcpp's algorithm (see :mod:`paramdds.core.listing`)."""
        if isinstance(depth, bool) or not isinstance(depth, int) or depth < 0:
            raise InvalidValueError(f"list depth must be an integer >= 0 (0 = recursive), got {depth!r}")
        if isinstance(prefixes, str) or not all(isinstance(p, str) for p in prefixes):
            raise InvalidValueError("list prefixes must be a list of strings")
        with self._lock:
            names, found = list_names(self._sorted_names(), list(prefixes), depth)
        return ListResult(tuple(names), tuple(found))

    def names(self) -> _Strings:
        """Every declared name, sorted."""
        with self._lock:
            return list(self._sorted_names())

    def snapshot(self) -> _Snapshot:
        """``(name, value, descriptor)`` for every parameter, sorted by name."""
        with self._lock:
            params = self._params
            return [(n, *params[n]) for n in self._sorted_names()]

    def __len__(self) -> int:
        return len(self._params)

    def _sorted_names(self) -> _Strings:
        if self._sorted is None:
            self._sorted = sorted(self._params)
        return self._sorted

    # --- declaring -------------------------------------------------------------------------

    def declare(
        self,
        name: str,
        default: ParameterValue | object = None,
        descriptor: ParameterDescriptor | None = None,
        *,
        ignore_override: bool = False,
    ) -> ParameterValue:
        """Declare ``name`` and return its value (the override when one is given, else the default).

        The type is ``descriptor.type``, or the default's (or override's) type when that
        is NOT_SET and the parameter is not dynamically typed. A typed parameter without
        any value is *required*: InvalidValueError. Raises InvalidNameError,
        AlreadyDeclaredError, TypeMismatchError, OutOfRangeError, InvalidValueError,
        TooLargeError; nothing changes when it raises.
        """
        with self._lock:
            self._guard("declare parameters")
            stage = _Stage(self._params)
            entry = self._plan_declare(name, default, descriptor, ignore_override, stage)
            self._commit_declared(stage)
            return entry[0]

    def declare_from(self, items: Iterable[tuple[str, ParameterValue, ParameterDescriptor | None]]) -> None:
        """Declare many parameters in one revision, all or nothing (same rules as :meth:`declare`)."""
        with self._lock:
            self._guard("declare parameters")
            stage = _Stage(self._params)
            for item in items:
                try:
                    name, default, descriptor = item
                except (TypeError, ValueError):
                    raise InvalidValueError(
                        f"declare_from takes (name, value, descriptor) triples, got {type(item).__name__}"
                    ) from None
                self._plan_declare(name, default, descriptor, False, stage)
            if stage.pending:
                self._commit_declared(stage)

    def _plan_declare(
        self,
        name: object,
        default: object,
        descriptor: object,
        ignore_override: bool,
        stage: _Stage,
    ) -> _Entry:
        name = validate_name(name)
        if descriptor is None:
            descriptor = ParameterDescriptor(name)
        if not isinstance(descriptor, ParameterDescriptor):
            raise InvalidValueError(f"Parameter {name!r}: expected a ParameterDescriptor")
        value = default if isinstance(default, ParameterValue) else ParameterValue.from_python(default)
        typed = value.type is ParameterType.NOT_SET and descriptor.type is not ParameterType.NOT_SET
        if typed and descriptor.dynamic_typing:
            # rclcpp's declare_parameter(name, type, descriptor) refuses this before anything else
            raise InvalidValueError(
                f"Parameter {name!r}: a declaration by type ({descriptor.type.label}) cannot also "
                "ask for dynamic_typing"
            )
        if stage.get(name) is not None:
            raise AlreadyDeclaredError(f"parameter {name!r} is already declared on node {self.node_id!r}")
        desc = replace(descriptor, name=name)
        if not typed and not desc.dynamic_typing:
            # rclcpp (declare_parameter_helper): the descriptor's type is a status that the
            # default's type overwrites; only a declaration without a default is typed by it.
            desc = replace(desc, type=value.type)
        check_text(name, "description", desc.description)
        check_text(name, "additional_constraints", desc.additional_constraints)
        override = None if ignore_override else self._overrides.get(name)
        chosen = override if override is not None else value
        if desc.dynamic_typing:
            check_descriptor(desc)
            if desc.type is not ParameterType.NOT_SET and chosen.type is ParameterType.NOT_SET:
                raise InvalidValueError(f"Parameter {name!r} is required but has no value")
            desc = replace(desc, type=chosen.type)
        else:
            declared = desc.type
            if declared is ParameterType.NOT_SET:
                # rclcpp and rclpy refuse it even when an override would give a value
                raise TypeMismatchError(
                    f"Parameter {name!r} has no type: give a default value, a descriptor type, "
                    "or dynamic_typing=True"
                )
            desc = replace(desc, type=declared)
            check_descriptor(desc)
            if chosen.type is ParameterType.NOT_SET:
                # rclcpp and rclpy: a statically typed parameter may be declared without a
                # value; reading it fails until it is set (see ``get``).
                stage.pending[name] = (chosen, desc)
                return chosen, desc
            chosen = chosen.coerce(declared, strict=self.strict_types, name=name)
        check_value(name, chosen)
        validate(name, chosen, desc)
        stage.pending[name] = (chosen, desc)
        return chosen, desc

    def _commit_declared(self, stage: _Stage) -> None:
        params = [Parameter(n, e[0]) for n, e in stage.pending.items() if e is not None]
        try:
            self._check_node(stage, [p.name for p in params])
            self._run_on_set(params)
        except _UnitFailed as failed:
            raise failed.error from None
        self._commit(stage, params)

    def undeclare(self, name: str) -> None:
        """Remove ``name``: NotFoundError, ReadOnlyError, or TypeMismatchError for a static type."""
        with self._lock:
            self._guard("undeclare parameters")
            _, desc = self._entry(name)
            if desc.read_only:
                raise ReadOnlyError(f"parameter {name!r} is read-only and cannot be undeclared")
            if not desc.dynamic_typing:
                raise TypeMismatchError(
                    f"parameter {name!r} is statically typed ({desc.type.label}) and cannot be "
                    "undeclared; declare it with dynamic_typing to allow that"
                )
            stage = _Stage(self._params)
            stage.pending[name] = None
            try:
                self._check_node(stage, [name])
            except _UnitFailed as failed:
                raise failed.error from None
            self._commit(stage, [], post_set=False)

    def mirror(self, entries: Mapping[str, _Entry | None]) -> ChangeSet | None:
        """Commit ``entries`` as they are (None deletes), in one revision, without validation
        or callbacks: for a table that mirrors a node whose own server already validated
        them (the ROS 2 bridge). Entries equal to what the table holds change nothing;
        the change listeners get the ChangeSet (None when nothing changed)."""
        with self._lock:
            self._guard("mirror parameters")
            stage = _Stage(self._params)
            for name, entry in entries.items():
                before = self._params.get(name)
                if entry != before:
                    stage.pending[name] = entry
            change, _ = self._commit(stage, [], post_set=False)
            return change

    # --- setting ---------------------------------------------------------------------------

    def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome:
        """Set each parameter on its own; the ones that pass are committed in one revision.

        Inside :func:`paramdds.core.deadline.applying` (a request's deadline, set by the
        server): past it by this host's clock at the commit point (after validation and the
        callbacks), raise EXPIRED and change nothing."""
        request = self._request(params)
        with self._lock:
            self._guard("set parameters")
            refused = self._refuse_all(request, expected_revision)
            if refused is not None:
                return refused
            stage = _Stage(self._params)
            results: list[SetResult] = []
            applied: list[Parameter] = []
            for p in request:
                trial = stage.trial()
                try:
                    unit, reason = self._attempt([p], trial)
                except _UnitFailed as failed:
                    results.append(SetResult(_name_of(p), False, failed.error.message, failed.error.code))
                    continue
                trial.keep()
                applied.extend(unit)
                results.append(SetResult(_name_of(p), True, reason))
            deadlines.check(deadlines.current())
            return self._finish(stage, applied, results)

    def set_atomically(
        self, params: Sequence[Parameter], *, expected_revision: int | None = None
    ) -> SetOutcome:
        """Set all the parameters or none of them (a request's deadline: as :meth:`set`)."""
        request = self._request(params)
        with self._lock:
            self._guard("set parameters")
            refused = self._refuse_all(request, expected_revision)
            if refused is not None:
                return refused
            stage = _Stage(self._params)
            try:
                applied, reason = self._attempt(list(request), stage)
            except _UnitFailed as failed:
                return SetOutcome(self._atomic_failure(request, failed), self.revision, None)
            results = [SetResult(_name_of(p), True, reason) for p in request]
            deadlines.check(deadlines.current())
            return self._finish(stage, applied, results)

    @staticmethod
    def _request(params: object) -> _Objects:
        if isinstance(params, (str, bytes, Mapping)) or not isinstance(params, Iterable):
            raise InvalidValueError(f"a set takes a list of Parameter, got {type(params).__name__}")
        return list(params)

    def _refuse_all(self, request: _Objects, expected_revision: int | None) -> SetOutcome | None:
        if expected_revision is not None and expected_revision != self.revision:
            reason = (
                f"not applied: node {self.node_id!r} is at revision {self.revision}, "
                f"not the expected {expected_revision}"
            )
            code: ErrorCode = ErrorCode.CONFLICT
        else:
            try:
                check_request_size(len(request))
            except TooLargeError as exc:
                reason, code = f"not applied: {exc.message}", exc.code
            else:
                return None
        results = tuple(SetResult(_name_of(p), False, reason, code) for p in request)
        return SetOutcome(results, self.revision, None)

    def _atomic_failure(self, request: _Objects, failed: _UnitFailed) -> tuple[SetResult, ...]:
        error = failed.error
        names = [_name_of(p) for p in request]
        if failed.name is None:  # a veto or a callback error: it concerns them all
            return tuple(SetResult(n, False, error.message, error.code) for n in names)
        other = f"not applied: the atomic set failed on {failed.name!r}"
        if failed.name not in names:
            other += f" ({error.message})"
        return tuple(
            SetResult(n, False, error.message, error.code)
            if n == failed.name
            else SetResult(n, False, other, ErrorCode.INVALID_VALUE)
            for n in names
        )

    def _attempt(self, params: _Objects, stage: _Stage) -> tuple[_Params, str]:
        """Steps 2-4 for one unit, writing into ``stage``. Raises _UnitFailed."""
        unit = self._run_pre_set(params)
        for p in unit:  # as rclcpp: every name is checked for being declared and writable first
            try:
                self._check_access(p, stage)
            except ParamddsError as exc:
                raise _UnitFailed(_name_of(p), exc) from None
        planned: _Params = []
        for p in unit:
            try:
                name, entry = self._plan_set(p, stage)
            except ParamddsError as exc:
                raise _UnitFailed(_name_of(p), exc) from None
            stage.pending[name] = entry
            planned.append(Parameter(name, entry[0] if entry is not None else NOT_SET))
        self._check_node(stage, [p.name for p in planned])
        return planned, self._run_on_set(planned)

    def _check_node(self, stage: _Stage, names: Sequence[str]) -> None:
        """The whole-node validator (see the module doc) on the state ``stage`` would leave."""
        if self._node_validator is None:
            return
        refusal = self._node_validator(stage.values(), {n: stage.before(n) for n in names})
        if refusal is not None:
            name, reason = refusal
            raise _UnitFailed(name or None, InvalidValueError(reason))

    def _check_access(self, p: object, stage: _Stage) -> None:
        """rclcpp's first pass over a request (set_parameters_atomically): a name that is not
        declared (unless allowed) or is read-only fails before any value is looked at."""
        if not isinstance(p, Parameter):
            return  # refused with a clear reason by _plan_set
        name = validate_name(p.name)
        if self.read_only:
            raise ReadOnlyError(f"node {self.node_id!r} is read-only")
        current = stage.get(name)
        if current is None and not self.allow_undeclared:
            raise _not_declared(name)
        if current is not None and current[1].read_only:
            raise ReadOnlyError(f"parameter {name!r} is read-only")

    def _plan_set(self, p: object, stage: _Stage) -> tuple[str, _Entry | None]:
        """Step 3 for one parameter: the entry it would leave (None: deleted), or raise.
        Read-only nodes and parameters were refused by :meth:`_check_access`; a name is
        checked for being declared again, as an earlier entry of the unit may delete it."""
        if not isinstance(p, Parameter):
            raise InvalidValueError(f"expected a Parameter, got {type(p).__name__}")
        name = validate_name(p.name)
        value = p.value if isinstance(p.value, ParameterValue) else ParameterValue.from_python(p.value)
        check_value(name, value)
        current = stage.get(name)
        if current is None:
            if not self.allow_undeclared:
                raise _not_declared(name)
            # rclcpp declares it, dynamically typed (a NOT_SET value: declared without a value)
            return name, (value, ParameterDescriptor(name, value.type, dynamic_typing=True))
        desc = current[1]
        if value.type is ParameterType.NOT_SET:
            if not desc.dynamic_typing:
                raise TypeMismatchError(
                    f"parameter {name!r} is statically typed ({desc.type.label}) and cannot be "
                    "deleted; declare it with dynamic_typing to allow that"
                )
            if current[0].type is ParameterType.NOT_SET:
                return name, current  # already unset: it stays declared, as in rclcpp
            return name, None
        if desc.dynamic_typing:
            if value.type is not desc.type:
                desc = replace(desc, type=value.type)
        else:
            value = value.coerce(desc.type, strict=self.strict_types, name=name)
        validate(name, value, desc)
        return name, (value, desc)

    # --- callbacks -------------------------------------------------------------------------

    def _run_pre_set(self, params: _Objects) -> _Objects:
        if not self._pre or not params:
            return params
        for handle in self._pre:
            typed = [p for p in params if isinstance(p, Parameter)]
            if len(typed) != len(params):
                return params  # malformed entries fail in validation, with a clear reason
            try:
                with self._in_callback():
                    out = handle.fn(typed)
            except Exception as exc:
                raise _UnitFailed(None, _callback_error("pre-set", exc)) from None
            if not isinstance(out, list) or not all(isinstance(p, Parameter) for p in out):
                raise _UnitFailed(
                    None,
                    InvalidValueError(
                        f"pre-set callback returned {type(out).__name__}, expected a list of Parameter"
                    ),
                )
            params = list(out)
        if not params:
            raise _UnitFailed(
                None, InvalidValueError("not applied: the pre-set callbacks left no parameter to set")
            )
        return params

    def _run_on_set(self, params: _Params) -> str:
        reasons: _Strings = []
        for handle in self._on:
            try:
                with self._in_callback():
                    veto = handle.fn(list(params))
            except Exception as exc:
                raise _UnitFailed(None, _callback_error("on-set", exc)) from None
            if not isinstance(veto, SetVeto):
                raise _UnitFailed(
                    None,
                    InvalidValueError(f"on-set callback returned {type(veto).__name__}, expected a SetVeto"),
                )
            if not veto.successful:
                reason = veto.reason or "rejected by an on-set callback"
                raise _UnitFailed(None, InvalidValueError(reason))
            if veto.reason:
                reasons.append(veto.reason)
        return "; ".join(reasons)

    @contextmanager
    def _in_callback(self) -> Iterator[None]:
        self._local.depth = getattr(self._local, "depth", 0) + 1
        try:
            yield
        finally:
            self._local.depth -= 1

    def _guard(self, action: str) -> None:
        if getattr(self._local, "depth", 0):
            raise CallbackError(
                f"cannot {action} of node {self.node_id!r} from inside a parameter callback or change "
                "listener; do it after the callback returns"
            )

    # --- committing ------------------------------------------------------------------------

    def _finish(self, stage: _Stage, applied: _Params, results: _Results) -> SetOutcome:
        change, post_failure = self._commit(stage, applied)
        if post_failure:
            note = f"applied, but {post_failure}"
            results = [
                replace(r, reason=f"{r.reason}; {note}" if r.reason else note) if r.successful else r
                for r in results
            ]
        # the revision of this commit (commit hooks may have committed more after it)
        return SetOutcome(tuple(results), change.revision if change is not None else self.revision, change)

    def _commit(
        self, stage: _Stage, applied: _Params, *, post_set: bool = True
    ) -> tuple[ChangeSet | None, str]:
        """Steps 5-7: write ``stage``, tell the listeners, run post-set.

        Returns the ChangeSet (None if nothing changed) and what a failing post-set said.
        """
        post_failure = ""
        changes: _Changes = []
        for name, entry in stage.pending.items():
            before = self._params.get(name)
            if entry is not None:
                if entry is before:
                    continue  # planned as "no change" (NOT_SET on an unset parameter)
                kind = ChangeKind.NEW if before is None else ChangeKind.CHANGED
                old = None if before is None else before[0]
                changes.append(ParameterChange(kind, name, entry[0], entry[1], old))
            elif before is not None:
                changes.append(ParameterChange(ChangeKind.DELETED, name, NOT_SET, before[1], before[0]))
        if not changes:
            return None, ""
        for c in changes:
            if c.kind is ChangeKind.DELETED:
                del self._params[c.name]
            else:
                self._params[c.name] = (c.value, c.descriptor)
            if c.kind is not ChangeKind.CHANGED:
                self._sorted = None
        self.revision += 1
        change = ChangeSet(self.node_id, self.revision, tuple(changes), origins.current(), time.time_ns())
        with self._in_callback():
            for handle in list(self._listeners):
                try:
                    handle.fn(change)
                except Exception:
                    log.exception("change listener %r of node %r failed", handle, self.node_id)
            for handle in list(self._post) if post_set else []:
                try:
                    handle.fn(list(applied))
                except Exception as exc:
                    log.exception("post-set callback %r of node %r failed", handle, self.node_id)
                    post_failure = f"a post-set callback failed: {type(exc).__name__}: {exc}"
        self._run_commit_hooks(change)
        return change, post_failure

    def _run_commit_hooks(self, change: ChangeSet) -> None:
        if not self._hooks or self._in_hooks:
            return
        self._in_hooks = True
        try:
            for handle in list(self._hooks):
                try:
                    handle.fn(change)
                except Exception:
                    log.exception("commit hook %r of node %r failed", handle, self.node_id)
        finally:
            self._in_hooks = False

    # --- registering callbacks -------------------------------------------------------------

    def _add(self, where: _Handles, kind: str, fn: Callable[..., object]) -> object:
        if not callable(fn):
            raise InvalidValueError(f"a {kind} callback must be callable, got {type(fn).__name__}")
        with self._lock:
            self._guard(f"add a {kind} callback")
            handle = _Handle(kind, fn)
            where.insert(0, handle)  # ROS 2: the last registered runs first
            return handle

    def add_pre_set_callback(self, cb: PreSetCallback) -> object:
        return self._add(self._pre, "pre-set", cb)

    def add_on_set_callback(self, cb: OnSetCallback) -> object:
        return self._add(self._on, "on-set", cb)

    def add_post_set_callback(self, cb: PostSetCallback) -> object:
        return self._add(self._post, "post-set", cb)

    def add_change_listener(self, fn: ChangeListener) -> object:
        """``fn`` gets every committed ChangeSet, in revision order (under the table's lock)."""
        with self._lock:
            self._guard("add a change listener")
            handle = _Handle("change listener", fn)
            self._listeners.append(handle)
            return handle

    def add_commit_hook(self, fn: ChangeListener) -> object:
        """``fn`` runs after each commit, outside callbacks, and may declare parameters.

        What it declares is a commit of its own (a new revision) that runs no hooks; an
        exception it raises is logged. Spec mapped parameters use it (see paramdds.formats.spec).
        """
        with self._lock:
            self._guard("add a commit hook")
            handle = _Handle("commit hook", fn)
            self._hooks.append(handle)
            return handle

    def set_node_validator(self, fn: NodeValidator | None) -> None:
        """Install (None: remove) the whole-node validator (see the module doc)."""
        with self._lock:
            self._guard("set the node validator")
            self._node_validator = fn

    def remove_callback(self, handle: object) -> None:
        with self._lock:
            self._guard("remove a callback")
            for where in (self._pre, self._on, self._post):
                if handle in where:
                    where.remove(handle)  # type: ignore[arg-type]
                    return
        raise NotFoundError(f"no such callback on node {self.node_id!r}: {handle!r}")

    def remove_change_listener(self, handle: object) -> None:
        with self._lock:
            self._guard("remove a change listener")
            if handle in self._listeners:
                self._listeners.remove(handle)  # type: ignore[arg-type]
                return
        raise NotFoundError(f"no such change listener on node {self.node_id!r}: {handle!r}")
