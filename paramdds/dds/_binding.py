"""Every use of cyclonedds-python's private API, in one place.

paramdds reaches below the binding's public API in a few places, each for a
measured reason:

* :func:`take_serialized` and :func:`write_serialized` move samples as CDR bytes
  (``cyclonedds._clayer.ddspy_take`` / ``ddspy_write``), so our generated codecs
  (:mod:`.cdr`, :mod:`.state`) replace the binding's generic interpreter on the
  hot paths;
* :func:`binding_deserialize` is the binding's own decoder, the fallback for
  samples our codec does not read;
* :func:`install_type_data` hands precomputed XTypes type data to a type's
  ``__idl__`` and :func:`compute_type_data` computes it (see :mod:`.typecache`);
* ``Endianness``, the binding's byte-order enum, for encoding big-endian samples;
* :func:`waitset_attach_indexed` and :func:`waitset_wait_indexed` attach entities
  to a WaitSet with a cookie of our choosing (the benchmarks' wake-up path);
* :func:`read_new_infos` reads the sample infos of samples not read before
  (``ddspy_read``) without decoding them: how the client's discovery watch sees
  which state writers have delivered, at no decoding cost;
* :func:`matched_publications` and :func:`matched_subscriptions` work around a race
  in the binding's matched-endpoint lists (a match while it asks raises IndexError);
* :func:`entity_handle` is the C handle of an entity (``_ref``), for calls into
  Cyclone's C API;
* :func:`live_endpoints` lists the readers and writers of a participant that exist
  as Python objects (the binding's entity registry), for :mod:`.peers`;
* :func:`assert_liveliness` asserts a MANUAL liveliness writer's liveliness
  (``dds_assert_liveliness``, which the binding does not wrap), so a server's
  dispatch loop, not Cyclone's own threads, keeps its nodes alive;
* :class:`BatchingWriter` and :func:`flush_writes` give a writer Cyclone's
  writer-batching QoS (``dds_qset_writer_batching``, set on the C QoS the binding
  builds) and send its batch (``dds_write_flush``): the state writer sends a set's
  samples, and the set-reply writer a group's replies, as one datagram per reader;
* :func:`dispose_serialized` and :func:`unregister_serialized` dispose or
  unregister an instance given as raw key bytes (the fault-injection tests send
  keys no encoder would write);
* :func:`install_native_filter` installs a C filter function (see
  :mod:`.filters`) on a topic with ``dds_set_topic_filter_and_arg``, through the
  binding's handle on the C library. The binding's samples reach it as its sample
  container (pointer and size of the CDR bytes, ``clayer/pysertype.c``);
* :data:`QOS_LOCK` serializes the binding's QoS conversions (see
  :func:`_serialize_qos_reads`), installed when this module is imported;
  :func:`take_participant_keys` takes the built-in participant topic's samples without
  converting any QoS at all (taken, not read: a read sample of a participant that left
  stays in the reader for good, ~1.4 KB each, a long-lived client's growth under churn).

All of them are checked against one binding version: importing this module with
another major.minor version of cyclonedds raises :class:`ImportError` naming
both, so an upgrade fails here, in one obvious place, rather than deep inside a
dispatch thread.
"""

from __future__ import annotations

import ctypes as ct
import functools
import threading
from pathlib import Path
from typing import Any

import cyclonedds

__all__ = [
    "QOS_LOCK",
    "SUPPORTED_VERSION",
    "BatchingWriter",
    "Endianness",
    "assert_liveliness",
    "binding_deserialize",
    "compute_type_data",
    "cookie_buffer",
    "dispose_serialized",
    "entity_handle",
    "flush_writes",
    "install_native_filter",
    "install_type_data",
    "installed_version",
    "live_endpoints",
    "matched_publications",
    "matched_subscriptions",
    "read_new_infos",
    "take_participant_keys",
    "take_serialized",
    "unregister_serialized",
    "waitset_attach_indexed",
    "waitset_wait_indexed",
    "write_serialized",
]

_MATCH_RETRIES = 8  # attempts at a matched-endpoint list while endpoints keep matching
SUPPORTED_VERSION = "11.0"  # major.minor of cyclonedds-python these calls were written against


def installed_version() -> str | None:
    """The installed cyclonedds version, read from its dist-info folder name (no importlib.metadata)."""
    site = Path(cyclonedds.__file__).parent.parent
    for info in site.glob("cyclonedds-*.dist-info"):
        return info.name[len("cyclonedds-") : -len(".dist-info")]
    return None


def _check_version() -> None:
    version = installed_version()
    if version is None:
        return  # a source checkout of the binding: nothing to compare, trust it
    if version.split(".")[:2] != SUPPORTED_VERSION.split("."):
        raise ImportError(
            f"paramdds uses private parts of cyclonedds-python {SUPPORTED_VERSION}.x "
            f"(paramdds/dds/_binding.py), but cyclonedds {version} is installed: "
            f"install cyclonedds>={SUPPORTED_VERSION},<{int(SUPPORTED_VERSION.split('.')[0]) + 1}"
        )


_check_version()

from cyclonedds._clayer import (  # noqa: E402  (after the version check)
    ddspy_dispose,
    ddspy_read,
    ddspy_take,
    ddspy_take_participant,
    ddspy_unregister_instance,
    ddspy_write,
)
from cyclonedds.builtin_types import participant_constructor  # noqa: E402
from cyclonedds.core import DDSException  # noqa: E402
from cyclonedds.idl._support import Endianness  # noqa: E402
from cyclonedds.internal import DDS  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.qos import _CQos  # noqa: E402

# -- QoS conversions: one at a time in the process ---------------------------------------
#
# The binding turns a C QoS into a Python ``Qos`` with ``_CQos._get_p_*`` class methods
# that use ctypes buffers stored on the *class* (``_CQos._gc_*``), shared by every thread:
# Cyclone writes into them, Python reads them back, and for the entity name the binding
# then frees the string Cyclone allocated. Two threads converting at once read each
# other's values (a ``UnicodeDecodeError`` on a half-written name, the wrong partitions) or
# free one string twice (``free(): double free detected in tcache 2``: the process
# aborts). Every conversion goes through those methods, whoever calls them:
#
# * a built-in topic's samples (DcpsParticipant, DcpsPublication, DcpsSubscription: the
#   binding converts each sample's QoS while reading, ``builtin_types.cqos_to_qos``);
# * ``Entity.get_qos()``, ``get_matched_publication_data`` / ``_subscription_data``;
# * ``QosProvider.get_*_qos`` (loading the QoS profiles);
# * creating a DataWriter (it reads back its data representation).
#
# The other direction (``Qos`` -> C, when an entity is created) allocates per call and
# needs no lock. So the getters are wrapped here, once, with one process-wide lock, and
# every caller is covered, paramdds's own modules and any other code in the process
# alike. Inside the lock only Cyclone's ``dds_qget_*`` accessors (pure reads of the
# QoS struct), ``dds_free`` and Python object creation run: nothing that waits for a
# Cyclone lock or for another thread.

QOS_LOCK = threading.RLock()


def _serialize_qos_reads() -> None:
    for name, attribute in list(vars(_CQos).items()):
        if (name.startswith("_get_p_") or name == "cqos_to_qos") and isinstance(attribute, classmethod):
            setattr(_CQos, name, classmethod(_under_qos_lock(attribute.__func__)))


def _under_qos_lock(function: Any) -> Any:
    @functools.wraps(function)
    def locked(*args: Any) -> Any:
        with QOS_LOCK:
            return function(*args)

    locked.__paramdds_locked__ = True  # type: ignore[attr-defined]
    return locked


if not getattr(_CQos.cqos_to_qos, "__paramdds_locked__", False):  # once per process, also on reload
    _serialize_qos_reads()


def _no_qos(_pointer: Any) -> None:
    return None


def take_participant_keys(reader: Any, condition: Any, count: int) -> list[Any]:
    """Take up to ``count`` samples of a built-in DcpsParticipant ``reader`` matching ``condition``
    (a ReadCondition of it), without their QoS: ``sample.qos`` is None.

    The binding would convert every sample's QoS (under :data:`QOS_LOCK`); the key and the
    sample info are all a discovery watch needs. Taken: Cyclone frees a participant's
    instance once it has left and holds no sample.
    """
    batch = ddspy_take_participant(condition._ref, count, participant_constructor, _no_qos)
    if isinstance(batch, int):
        raise DDSException(batch, f"Occurred while taking data in {reader!r}")
    return batch  # type: ignore[no-any-return]


def entity_handle(entity: Any) -> int:
    """The Cyclone C handle of a binding entity (reader, writer, topic, waitset…)."""
    return int(entity._ref)


def live_endpoints(participant: Any) -> list[Any]:
    """Every DataReader and DataWriter of ``participant`` that has a Python object now."""
    from cyclonedds.core import Entity
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader

    handle = participant._ref
    found = []
    for entity in list(Entity._entities.values()):
        if isinstance(entity, (DataReader, DataWriter)):
            try:
                if entity.participant is not None and entity.participant._ref == handle:
                    found.append(entity)
            except DDSException:  # deleted meanwhile
                continue
    return found


def matched_publications(reader: Any) -> list[int]:
    """``reader.get_matched_publications()``, safe against a writer matching meanwhile.

    The binding asks Cyclone for the count, allocates an array of that size and asks
    again; a match in between makes the second answer larger than the array, and the
    binding raises ``IndexError("invalid index")``. Asked again, the count is current.
    """
    return _settled(reader.get_matched_publications)


def matched_subscriptions(writer: Any) -> list[int]:
    """``writer.get_matched_subscriptions()``, safe like :func:`matched_publications`."""
    return _settled(writer.get_matched_subscriptions)


def _settled(listing: Any) -> list[int]:
    for _ in range(_MATCH_RETRIES):
        try:
            return list(listing())
        except IndexError:
            continue
    return list(listing())


def take_serialized(reader: Any, mask: int, count: int) -> list[tuple[bytes, Any]]:
    """Take up to ``count`` samples of ``reader`` as ``(CDR bytes, SampleInfo)`` pairs.

    For an invalid sample (dispose, unregister) the bytes are its serialized key.
    """
    batch = ddspy_take(reader._ref, mask, count)
    if isinstance(batch, int):
        raise DDSException(batch, f"Occurred while taking data in {reader!r}")
    return batch  # type: ignore[no-any-return]


def read_new_infos(reader: Any, mask: int, count: int) -> list[Any]:
    """The SampleInfos of up to ``count`` samples of ``reader`` matching ``mask``, marking them read.

    The samples stay in the reader; their bytes are copied by the binding but never decoded.
    """
    batch = ddspy_read(reader._ref, mask, count)
    if isinstance(batch, int):
        raise DDSException(batch, f"Occurred while reading data in {reader!r}")
    return [info for _, info in batch]


def write_serialized(writer: Any, data: bytes) -> None:
    """Write one sample already encoded as CDR (encapsulation header included)."""
    ret = ddspy_write(writer._ref, data)
    if ret < 0:
        raise DDSException(ret, f"Occurred while writing to {writer!r}")


def dispose_serialized(writer: Any, data: bytes) -> None:
    """Dispose the instance whose key is in ``data`` (a serialized sample, header included)."""
    ret = ddspy_dispose(writer._ref, data)
    if ret < 0:
        raise DDSException(ret, f"Occurred while disposing with {writer!r}")


def unregister_serialized(writer: Any, data: bytes) -> None:
    """Unregister the instance whose key is in ``data`` (a serialized sample, header included)."""
    ret = ddspy_unregister_instance(writer._ref, data)
    if ret < 0:
        raise DDSException(ret, f"Occurred while unregistering with {writer!r}")


@functools.cache
def _ddsc() -> ct.CDLL:
    """Cyclone's C library as the binding loaded it, with the few calls it does not wrap."""
    from cyclonedds.internal import load_cyclonedds

    lib = load_cyclonedds()
    lib.dds_assert_liveliness.restype = ct.c_int32
    lib.dds_assert_liveliness.argtypes = [ct.c_int32]
    lib.dds_qset_writer_batching.restype = None
    lib.dds_qset_writer_batching.argtypes = [ct.c_void_p, ct.c_bool]
    lib.dds_write_flush.restype = ct.c_int32
    lib.dds_write_flush.argtypes = [ct.c_int32]
    return lib


def assert_liveliness(entity: Any) -> None:
    """Assert the liveliness of a MANUAL_BY_TOPIC writer (or MANUAL_BY_PARTICIPANT participant)."""
    ret = _ddsc().dds_assert_liveliness(entity._ref)
    if ret < 0:
        raise DDSException(ret, f"Occurred while asserting the liveliness of {entity!r}")


class BatchingWriter(DataWriter[Any]):  # type: ignore[misc]  # the binding is untyped
    """A DataWriter with Cyclone's writer-batching QoS: its samples wait in one message
    until :func:`flush_writes`, so a burst goes out as one datagram per reader, not one per
    sample. A sample never flushed is not lost, only late: reliability's heartbeats have it
    resent (tests/dds/test_integration_batching.py checks that it is flushed)."""

    def _create_writer(self, publisher: Any, topic: Any, qos: Any, listener: Any) -> Any:
        if not qos:
            raise ValueError("a batching writer needs a QoS")
        _ddsc().dds_qset_writer_batching(qos, True)
        return super()._create_writer(publisher, topic, qos, listener)


def flush_writes(writer: Any) -> None:
    """Send what a :class:`BatchingWriter` holds."""
    ret = _ddsc().dds_write_flush(writer._ref)
    if ret < 0:
        raise DDSException(ret, f"Occurred while flushing {writer!r}")


def binding_deserialize(cls: type, data: bytes, has_header: bool, use_version_2: bool | None) -> Any:
    """Decode ``data`` with the binding's own generic interpreter."""
    return cls.__idl__.deserialize(data, has_header, use_version_2)  # type: ignore[attr-defined]


def install_type_data(cls: type, bytedata: tuple[bytes, bytes]) -> None:
    """Give ``cls`` precomputed XTypes (TypeInformation, TypeMapping) bytes.

    ``Topic()`` then uses them as they are; the typed objects (``get_type_info()``
    and friends) are still built by the binding, on first use only.
    """
    idl = cls.__idl__  # type: ignore[attr-defined]
    build = idl.fill_type_data  # the binding's own: builds the objects and the bytes

    def fill_type_data() -> None:  # what Topic() calls: it needs only the bytes
        if idl._xt_bytedata[0] is None:
            idl._xt_bytedata = bytedata

    def built(index: int) -> Any:
        if idl._xt_data[0] is None:
            build()
        return idl._xt_data[index]

    idl.fill_type_data = fill_type_data
    idl.get_type_info = lambda: built(0)
    idl.get_type_mapping = lambda: built(1)
    idl.get_type_id = lambda: built(0).complete.typeid_with_size.type_id


def compute_type_data(cls: type) -> tuple[bytes, bytes]:
    """The binding's own XTypes (TypeInformation, TypeMapping) bytes for ``cls``, built from scratch."""
    from cyclonedds.idl._xt_builder import XTBuilder

    info, mapping = XTBuilder.process_type(cls)
    return tuple(  # type: ignore[return-value]
        x.serialize(endianness=Endianness.Little, use_version_2=True)[4:] for x in (info, mapping)
    )


def waitset_attach_indexed(waitset: Any, entity: Any, cookie: int) -> None:
    """Attach ``entity`` to ``waitset`` with ``cookie`` (non-zero) as what ``wait`` returns for it."""
    ret = waitset._waitset_attach(waitset._ref, entity._ref, cookie)
    if ret < 0:
        raise DDSException(ret, f"Occurred while attaching {entity!r} to a waitset")
    waitset.attached.append((entity, None))


def waitset_wait_indexed(waitset: Any, buffer: Any, timeout_ns: int) -> list[int]:
    """Wait on ``waitset``; the cookies of the entities that triggered (``buffer``: c_void_p array)."""
    ret = waitset._waitset_wait(waitset._ref, buffer, len(buffer), timeout_ns)
    if ret < 0:
        raise DDSException(ret, "Occurred while waiting on a waitset")
    return [int(buffer[i] or 0) for i in range(min(ret, len(buffer)))]


def cookie_buffer(capacity: int) -> Any:
    """A buffer for :func:`waitset_wait_indexed`."""
    return (ct.c_void_p * capacity)()


# void dds_set_topic_filter_and_arg(dds_entity_t topic, dds_topic_filter_arg_fn filter, void *arg):
# a prototype of our own, so the binding's own declaration of it is left untouched
_set_topic_filter_and_arg = ct.CFUNCTYPE(None, ct.c_int32, ct.c_void_p, ct.c_void_p)(
    ("dds_set_topic_filter_and_arg", DDS._dll_handle)
)


def install_native_filter(topic: Any, function: int, argument: int) -> None:
    """Install the C filter at address ``function`` with ``argument`` on ``topic``.

    Call it before creating the topic's reader. The caller keeps whatever
    ``argument`` points to alive as long as a reader of ``topic`` exists.
    """
    _set_topic_filter_and_arg(int(topic._ref), function, argument)
