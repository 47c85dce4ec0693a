"""QoS profiles: the DDS-XML file in ``qos/`` and the topic → profile mapping.

The profiles live in ``qos/DDS_QOS_PROFILES.xml`` (library ``paramdds``), read
with Cyclone's own ``QosProvider``. Which profile a topic uses is decided here,
by ordered name patterns where the first match wins, because Cyclone 11.0.1
rejects the vendor ``topic_filter`` attribute that would otherwise carry it::

    ParameterEvents  -> paramdds::State
    *Request         -> paramdds::Request
    *Response        -> paramdds::Reply

``paramdds::Assignment`` has no topic of its own: it is the QoS of the retained
(TRANSIENT_LOCAL) writer and reader on ``SetParametersRequest``. The answers to
assignments go through a writer and reader of their own on ``SetParametersResponse``:
the Reply profile made TRANSIENT_LOCAL here (:meth:`QosProfiles.answer_writer`),
so a file written for the four profiles still loads.

Loading costs well under a millisecond once ``cyclonedds`` is imported (the
import itself is deferred to :meth:`QosProfiles.load`). Every profile is read
at load time, so a user file (``-q FILE``) that is missing, malformed or lacks
a profile fails at once with a :class:`~paramdds.errors.FileFormatError` naming
the file and the profile, never later at the first write. The packaged file is
not checked again by every process (its tests check it): a one-shot command then
imports neither ``xml.etree`` nor ``importlib.resources``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import FileFormatError

if TYPE_CHECKING:
    from cyclonedds.qos import Qos

__all__ = ["ASSIGNMENT", "LIBRARY", "PROFILES", "TOPIC_PROFILES", "QosProfiles", "default_path"]

LIBRARY = "paramdds"
ASSIGNMENT = "Assignment"
PROFILES = ("State", "Request", "Reply", ASSIGNMENT)
ANSWERS_KEPT = 16  # answers to assignments a server keeps per node, for assigners that match late

TOPIC_PROFILES: tuple[tuple[str, str], ...] = (
    ("ParameterEvents", "State"),
    ("*Request", "Request"),
    ("*Response", "Reply"),
)
"""Ordered (topic name pattern, profile) pairs; the first pattern that matches wins."""

_ENTITIES = ("datawriter_qos", "datareader_qos")
_FILE_NAME = "DDS_QOS_PROFILES.xml"


def default_path() -> Path:
    """The packaged ``DDS_QOS_PROFILES.xml`` (the repository's ``qos/``) as a file-system path."""
    from importlib.util import find_spec

    spec = find_spec("paramdds.dds.wire.profiles")  # the package itself is never imported
    for folder in (spec.submodule_search_locations or []) if spec else []:
        path = Path(folder) / _FILE_NAME
        if path.is_file():
            return path
    from importlib.resources import as_file, files

    with as_file(files("paramdds.dds.wire.profiles") / _FILE_NAME) as found:  # a zip install, say
        return Path(found)


@dataclass(frozen=True)
class _Profile:
    """One profile's writer and reader QoS."""

    writer: Qos
    reader: Qos


class QosProfiles:
    """The four paramdds profiles read from one DDS-XML file.

    Build it with :meth:`load`. The returned ``Qos`` objects are shared: treat
    them as read-only (combine with ``+`` to derive a new one).
    """

    def __init__(self, path: Path, profiles: dict[str, _Profile]) -> None:
        self.path = path
        self._profiles = profiles

    @classmethod
    def load(cls, path: str | os.PathLike[str] | None = None) -> QosProfiles:
        """Read the profiles from ``path``, or the packaged file when ``path`` is None.

        Raises :class:`FileFormatError` when the file is missing, is not
        well-formed XML, lacks library ``paramdds`` or one of its profiles, or
        Cyclone refuses a QoS in it.
        """
        file = default_path() if path is None else Path(path)
        shown = str(file)
        if path is not None:  # a user's file; ours is checked by the tests
            _precheck(file, shown)
        from cyclonedds.core import DDSException
        from cyclonedds.qos_provider import QosProvider

        from . import _binding  # noqa: F401  (the provider converts QoS: under the binding's lock)

        try:
            provider = QosProvider(str(file))
        except DDSException as exc:
            raise FileFormatError(f"Cyclone DDS cannot load this QoS file: {exc}", file=shown) from exc
        profiles: dict[str, _Profile] = {}
        for name in PROFILES:
            key = f"{LIBRARY}::{name}"
            try:
                profiles[name] = _Profile(
                    writer=provider.get_datawriter_qos(key),
                    reader=provider.get_datareader_qos(key),
                )
            except DDSException as exc:
                raise FileFormatError(f"QoS profile {key!r} cannot be read: {exc}", file=shown) from exc
        return cls(file, profiles)

    def profile_for(self, topic: str) -> str:
        """The qualified profile name of a topic: ``"paramdds::State"``."""
        return f"{LIBRARY}::{_profile_name(topic)}"

    def writer(self, topic: str) -> Qos:
        """Writer QoS for a topic, by topic name."""
        return self._profiles[_profile_name(topic)].writer

    def reader(self, topic: str) -> Qos:
        """Reader QoS for a topic, by topic name."""
        return self._profiles[_profile_name(topic)].reader

    def assignment_writer(self) -> Qos:
        """QoS of the retained (TRANSIENT_LOCAL) writer on ``SetParametersRequest``."""
        return self._profiles[ASSIGNMENT].writer

    def assignment_reader(self) -> Qos:
        """QoS of the retained (TRANSIENT_LOCAL) reader on ``SetParametersRequest``."""
        return self._profiles[ASSIGNMENT].reader

    def answer_writer(self) -> Qos:
        """QoS of a server's writer of the answers to assignments on ``SetParametersResponse``:
        the Reply profile, TRANSIENT_LOCAL keeping the newest :data:`ANSWERS_KEPT` per node.

        An assigner's reader may match after the node answered (each side discovers the other's
        endpoints on its own): a volatile answer written before both matched never reaches it.
        An assigner draws a new client id each run, so no answer meant for another run reaches it.
        """
        from cyclonedds.qos import Policy, Qos

        kept = Policy.History.KeepLast(ANSWERS_KEPT)
        return self._profiles["Reply"].writer + Qos(
            Policy.Durability.TransientLocal,
            Policy.DurabilityService(0, kept, -1, -1, -1),
        )

    def answer_reader(self) -> Qos:
        """QoS of an assigner's reader of its answers: the Reply profile, TRANSIENT_LOCAL (it
        matches only :meth:`answer_writer`, never the volatile interactive reply writers)."""
        from cyclonedds.qos import Policy, Qos

        return self._profiles["Reply"].reader + Qos(Policy.Durability.TransientLocal)


def _profile_name(topic: str) -> str:
    for pattern, profile in TOPIC_PROFILES:
        if fnmatchcase(topic, pattern):
            return profile
    raise ValueError(f"no QoS profile for topic {topic!r}")


def _local(tag: str) -> str:
    return tag.rpartition("}")[2]


def _precheck(file: Path, shown: str) -> None:
    """Fail with a clear message before Cyclone prints its own terse errors to stderr."""
    import xml.etree.ElementTree as ET

    if not file.is_file():
        raise FileFormatError("QoS file not found", file=shown)
    try:
        root = ET.parse(file).getroot()
    except ET.ParseError as exc:
        raise FileFormatError(f"not well-formed XML: {exc}", file=shown, line=exc.position[0]) from exc
    except OSError as exc:
        raise FileFormatError(f"cannot read QoS file: {exc}", file=shown) from exc
    libraries = [e for e in root if _local(e.tag) == "qos_library" and e.get("name") == LIBRARY]
    if not libraries:
        raise FileFormatError(f"no <qos_library name={LIBRARY!r}>", file=shown)
    for name in PROFILES:
        found = [
            p for lib in libraries for p in lib if _local(p.tag) == "qos_profile" and p.get("name") == name
        ]
        if not found:
            raise FileFormatError(f"QoS profile '{LIBRARY}::{name}' is missing", file=shown)
        present = {_local(e.tag) for e in found[0]}
        for entity in _ENTITIES:
            if entity not in present:
                raise FileFormatError(f"QoS profile '{LIBRARY}::{name}' has no <{entity}>", file=shown)
