"""The precomputed XTypes type data must be exactly what the binding would build."""

from __future__ import annotations

from cyclonedds.idl._main import IDL

from paramdds.dds.wire import _typeobjects, regen_typecache, typecache
from paramdds.dds.wire import types as wire


def test_the_cache_matches_types_py_and_this_binding() -> None:
    # fails after a change to types.py: run `python -m paramdds.dds.wire.regen_typecache`, commit the result
    assert regen_typecache.compute(list(wire.TOPICS.values())) == _typeobjects.TYPE_DATA


def test_topics_get_the_cached_bytes_and_the_objects_still_build() -> None:
    for cls in wire.TOPICS.values():
        info, mapping = _typeobjects.TYPE_DATA[cls.__idl_typename__]
        idl = cls.__idl__
        idl.fill_type_data()  # what Topic() calls
        assert idl._xt_bytedata == (bytes.fromhex(info), bytes.fromhex(mapping))
        type_id = idl.get_type_id()  # built on demand, from the binding's own code
        fresh = IDL(cls)
        fresh.fill_type_data()
        assert type_id == fresh.get_type_id()
        assert fresh._xt_bytedata == idl._xt_bytedata


def test_the_cache_applies_to_the_installed_binding() -> None:
    assert typecache.install([]) is True
