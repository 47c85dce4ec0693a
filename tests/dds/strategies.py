"""Hypothesis strategies: any wire sample the IDL allows (no NaN, short strings), and core
values and descriptors of every shape with the arguments of a server's state sample."""

import dataclasses
import struct
import typing
from typing import Any, NamedTuple

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import bounded_str, sequence
from hypothesis import strategies as st

from paramdds.core.descriptors import (
    VALIDATOR_ARITY,
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    Validator,
)
from paramdds.core.values import NOT_SET, ParameterType, ParameterValue

_INTS = {
    "byte": (0, 2**8 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}
_TEXT = st.text(st.characters(exclude_categories=("Cs",)), max_size=12)


def _strategy(hint: Any) -> st.SearchStrategy[Any]:
    if hint is bool:
        return st.booleans()
    if hint is str:
        return _TEXT
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return samples(hint)
    meta = typing.get_args(hint)[1]
    if meta == "float64":
        return st.floats(allow_nan=False)
    if isinstance(meta, str):
        return st.integers(*_INTS[meta])
    if isinstance(meta, bounded_str):
        return st.text(st.characters(exclude_categories=("Cs",)), max_size=meta.max_length // 4)
    assert isinstance(meta, sequence), hint
    return st.lists(_strategy(meta.subtype), max_size=min(meta.max_length or 3, 3))


def samples(cls: type[IdlStruct]) -> st.SearchStrategy[Any]:
    hints = typing.get_type_hints(cls, include_extras=True)
    return st.builds(cls, **{name: st.deferred(lambda h=h: _strategy(h)) for name, h in hints.items()})


# ---- core values and descriptors of every shape, for the state fast path ----------------------

_T = ParameterType
_INT64 = st.integers(-(2**63), 2**63 - 1)
_ELEMENTS: dict[ParameterType, st.SearchStrategy[Any]] = {
    _T.BOOL: st.booleans(),
    _T.INTEGER: _INT64,
    _T.DOUBLE: st.floats(),  # NaN, infinities and -0.0 included: compare with `canonical`
    _T.STRING: _TEXT,
}


def _values_of(ptype: ParameterType) -> st.SearchStrategy[ParameterValue]:
    if ptype is _T.NOT_SET:
        return st.just(NOT_SET)
    if ptype is _T.BYTE_ARRAY:
        return st.binary(max_size=6).map(lambda b: ParameterValue(ptype, b))
    element = ptype.element
    items = _ELEMENTS[ptype] if element is None else st.lists(_ELEMENTS[element], max_size=4)
    return items.map(lambda x: ParameterValue.of(ptype, x))


def core_values() -> st.SearchStrategy[ParameterValue]:
    """Any value of any of the ten types."""
    return st.sampled_from(ParameterType).flatmap(_values_of)


def core_descriptors(
    name: st.SearchStrategy[str] = _TEXT, ptype: st.SearchStrategy[ParameterType] | None = None
) -> st.SearchStrategy[ParameterDescriptor]:
    """Any descriptor: ranges with any numbers, validators (known kinds or any text) with any values."""
    validators = st.builds(
        Validator,
        kind=st.sampled_from(sorted(VALIDATOR_ARITY)) | _TEXT,
        args=st.lists(core_values(), max_size=2).map(tuple),
    )
    return st.builds(
        ParameterDescriptor,
        name=name,
        type=st.sampled_from(ParameterType) if ptype is None else ptype,
        description=_TEXT,
        additional_constraints=_TEXT,
        read_only=st.booleans(),
        dynamic_typing=st.booleans(),
        integer_range=st.none() | st.builds(IntegerRange, _INT64, _INT64, st.integers(0, 2**64 - 1)),
        floating_point_range=st.none() | st.builds(FloatingPointRange, st.floats(), st.floats(), st.floats()),
        validators=st.lists(validators, max_size=3).map(tuple),
    )


class StateArgs(NamedTuple):
    """What a server publishes for one parameter (the arguments of ``encode_state``)."""

    node_id: str
    name: str
    revision: int
    sec: int
    nanosec: int
    value: ParameterValue
    descriptor: ParameterDescriptor
    incarnation: int = 0
    who: str = ""
    verified: bool = False
    via: str = ""


_KEY = st.text(st.characters(exclude_categories=("Cs",)), max_size=40).filter(
    lambda s: len(s.encode()) <= 255
)
_TEXT = st.text(st.characters(exclude_categories=("Cs",)), max_size=40)


@st.composite
def state_args(draw: st.DrawFn) -> StateArgs:
    """A parameter of any type whose descriptor is plain (name and type only), describes it
    (same name and type, the server's case) or is any descriptor at all."""
    name = draw(_KEY)
    value = draw(core_values())
    descriptor = draw(
        st.one_of(
            st.just(ParameterDescriptor(name, value.type)),
            core_descriptors(st.just(name), st.just(value.type)),
            core_descriptors(),
        )
    )
    return StateArgs(
        draw(_KEY),
        name,
        draw(_INT64),
        draw(st.integers(-(2**31), 2**31 - 1)),
        draw(st.integers(0, 2**32 - 1)),
        value,
        descriptor,
        draw(st.integers(0, 2**64 - 1)),
        draw(st.one_of(st.just(""), st.just("alice@robot-host"), _TEXT)),
        draw(st.booleans()),
        draw(st.one_of(st.sampled_from(["", "cli", "api", "start"]), _TEXT)),
    )


def canonical(obj: object) -> object:
    """``obj`` with its exact types and every float as its bits: two results are equal here
    only if a user cannot tell them apart (NaN is NaN, -0.0 is not 0.0, True is not 1,
    a tuple is not a list)."""
    if isinstance(obj, float):
        return ("float", struct.pack("<d", obj))
    if isinstance(obj, (tuple, list)):
        return (type(obj).__name__, tuple(canonical(x) for x in obj))
    if dataclasses.is_dataclass(obj):
        return (type(obj).__name__, tuple(canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)))
    return (type(obj).__name__, obj)
