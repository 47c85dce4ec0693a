"""Who wrote a request, as DDS Security authenticated it: the certificate subject behind a sample.

Cyclone does not hand the application a remote participant's authenticated certificate:
the identity token (``dds.cert.sn``) and the permissions token stay inside DDSI and
never reach a built-in topic sample. What it does expose is the participant's GUID,
and under DDS Security that GUID is derived from the certificate: the authentication
plugin sets the first 48 bits of the GUID prefix to a flag bit and the first 47 bits of
SHA-256 over the DER-encoded certificate subject (``get_adjusted_participant_guid`` in
Cyclone's ``authentication.c``), and during the handshake it refuses a peer whose
participant data carries a key that does not derive from the certificate it presented.

So a paramdds participant made with an identity announces its certificate (public data)
in a propagated participant property, :data:`paramdds.dds.participant.CERTIFICATE_PROPERTY`,
and :class:`Authenticator` answers, for a request sample:

1. the sample's writer (``SampleInfo.publication_handle``) -> its participant's key, from
   the ``DCPSPublication`` built-in topic;
2. that participant's ``DCPSParticipant`` sample -> the announced certificate;
3. the certificate is signed by this process's identity CA, and the participant's key
   derives from the certificate's subject (:func:`subject_of`): then the subject, in
   the RFC 4514 form the permissions grant on (``O=paramdds,CN=op1``), is the writer.

Anything else (no certificate announced: a foreign or older peer; a certificate of
another CA; a key that is not the certificate's) gives None: the server records the
request's claim, unverified. What this does not verify: that Cyclone bound the
handshake's participant data to the GUID the peer announces in discovery (11.0.1
checks the data against the certificate, and we found no check against the GUID), so
a modified DDS stack holding a valid certificate of its own could announce another
subject's GUID prefix; and 47 bits of a hash, which a CA that issues subjects freely
would let an attacker search.
"""

from __future__ import annotations

import hashlib
import logging
import threading
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from cryptography.x509 import Certificate

__all__ = ["Authenticator", "adjusted_prefix", "authenticator_for", "load_ca", "subject_of"]

log = logging.getLogger(__name__)

_FLAG = 0x80  # ADJUSTED_GUID_PREFIX_FLAG: the top bit of a secure participant's GUID prefix
_CACHE_MAX = 4096  # writers remembered (a server sees one per client participant and topic)
_READ_MAX = 100_000  # built-in samples read at once
_MASK = (1 << 64) - 1  # instance handles are unsigned 64-bit


def adjusted_prefix(subject_der: bytes) -> bytes:
    """The first 6 bytes of the GUID prefix DDS Security gives a participant whose
    certificate subject is ``subject_der`` (DER): the flag bit, then 47 bits of SHA-256."""
    high = hashlib.sha256(subject_der).digest()
    out = bytearray(6)
    carry = _FLAG
    for i in range(6):
        out[i] = carry | high[i] >> 1
        carry = (high[i] << 7) & 0xFF
    return bytes(out)


def load_ca(ca_pem: bytes) -> Certificate:
    """The identity CA's certificate, loaded (and OpenSSL's verification made ready: the
    first verification in a process costs ~0.1 s, paid here rather than by a request)."""
    from cryptography import x509

    ca = x509.load_pem_x509_certificate(ca_pem)
    ca.verify_directly_issued_by(ca)  # self-signed
    return ca


def subject_of(certificate_pem: str, participant_key: bytes, ca: Certificate) -> str | None:
    """The certificate's subject (RFC 4514) when the certificate is signed by ``ca`` (see
    :func:`load_ca`) and ``participant_key`` (the 16-byte GUID) derives from its subject;
    None otherwise."""
    from cryptography import x509
    from cryptography.exceptions import InvalidSignature

    try:
        cert = x509.load_pem_x509_certificate(certificate_pem.encode())
        cert.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature) as exc:
        log.debug("certificate not verified: %s", exc)
        return None
    if participant_key[:6] != adjusted_prefix(cert.subject.public_bytes()):
        return None
    return cert.subject.rfc4514_string()


class Authenticator:
    """``ParameterServer.authenticate`` for a secure participant: request sample -> the
    certificate subject of its writer's participant, or None (see the module docstring).

    Answers are cached per writer (Cyclone never reuses an instance handle in a process).
    The built-in readers are made once, here; a writer not seen before makes it read
    what they hold (the binding reads no single instance of a built-in topic), indexed by
    instance handle, which for a built-in topic is the entity's (``SampleInfo``'s
    ``publication_handle`` is the writer's).
    """

    def __init__(self, participant: Any, ca_pem: bytes) -> None:
        from cyclonedds.builtin import (
            BuiltinDataReader,
            BuiltinTopicDcpsParticipant,
            BuiltinTopicDcpsPublication,
        )

        from ..dds.participant import CERTIFICATE_PROPERTY

        self._property = CERTIFICATE_PROPERTY
        self._ca = load_ca(ca_pem)
        self._publications = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        self._participants = BuiltinDataReader(participant, BuiltinTopicDcpsParticipant)
        self._lock = threading.Lock()
        self._by_writer: dict[int, str | None] = {}
        self._writers: dict[int, int] = {}  # writer -> its participant (instance handles)
        self._announced: dict[int, tuple[bytes, str]] = {}  # participant -> (key, certificate)
        self._warned: set[bytes] = set()

    def __call__(self, sample: Any) -> str | None:
        info = getattr(sample, "sample_info", None)
        handle = int(getattr(info, "publication_handle", 0) or 0) & _MASK
        if handle == 0:
            return None
        with self._lock:
            if handle in self._by_writer:
                return self._by_writer[handle]
            found = self._lookup(handle)
            if len(self._by_writer) >= _CACHE_MAX:
                self._by_writer.clear()
            self._by_writer[handle] = found
            return found

    def _lookup(self, handle: int) -> str | None:
        if handle not in self._writers:
            self._refresh()
        participant = self._writers.get(handle)
        if participant is None:
            return None  # the writer is gone
        if participant not in self._announced:
            self._refresh()
        found = self._announced.get(participant)
        if found is None:
            return None
        key, pem = found
        if not pem:
            return None  # no certificate announced: a foreign or older peer, its claim stands
        subject = subject_of(pem, key, self._ca)
        if subject is None and key not in self._warned:
            self._warned.add(key)
            log.warning(
                "participant %s announces a certificate that is not its own (or not of this "
                "keystore's identity CA): its requests are recorded as unverified claims",
                uuid.UUID(bytes=key),
            )
        return subject

    def _refresh(self) -> None:
        from cyclonedds.qos import Policy

        if len(self._writers) >= _CACHE_MAX or len(self._announced) >= _CACHE_MAX:
            self._writers.clear()
            self._announced.clear()
        for pub in self._publications.read(N=_READ_MAX):
            writer = int(pub.sample_info.instance_handle) & _MASK
            self._writers[writer] = int(pub.participant_instance_handle) & _MASK
        for part in self._participants.read(N=_READ_MAX):
            props = {q.key: q.value for q in part.qos if isinstance(q, Policy.Property)}
            announced = (part.key.bytes, str(props.get(self._property, "")))
            self._announced[int(part.sample_info.instance_handle) & _MASK] = announced


def authenticator_for(participant: Any) -> Callable[[Any], str | None] | None:
    """An :class:`Authenticator` for a participant made with an identity; None in plain mode."""
    grants = getattr(getattr(participant, "transport", None), "grants", None)
    if grants is None:
        return None
    ca = Path(grants.path) / "identity_ca.pem"
    return Authenticator(participant, ca.read_bytes())
