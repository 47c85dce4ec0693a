"""Hypothesis strategies for the wire types: any sample the IDL allows (no NaN, short strings)."""

import typing
from typing import Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import bounded_str, sequence
from hypothesis import strategies as st

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
