"""The wire: the seven topic types (:mod:`.types`, matching ``idl/paramdds.idl``), their XCDR1
codecs (:mod:`.cdr`, and :mod:`.state` / :mod:`.state_cdr` for ``ParameterEvents``), the
conversions between core values and wire samples (:mod:`.convert`), and the precomputed XTypes
type information (:mod:`.typecache`).

Nothing here creates a DDS entity: the roles in :mod:`paramdds.dds` do, with these types.
The repository's ``idl/`` and ``qos/`` folders are installed beside them as data
(``paramdds.dds.wire.idl_source`` and ``paramdds.dds.wire.profiles``).
"""
