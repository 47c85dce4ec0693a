"""What :func:`paramdds.dds.participant.make_participant` calls in secure mode."""

from __future__ import annotations

from typing import Any

from ..errors import NotPermittedError
from .identity import Identity, check_domain, require_secure_library
from .scope import Scope

__all__ = ["prepare_secure", "secure_participant"]


def prepare_secure(identity: Identity, domain_id: int) -> str:
    """Check the domain id and the library; the ``<Security>`` configuration element."""
    check_domain(domain_id)
    require_secure_library()
    return identity.security_xml()


def secure_participant(domain_id: int, qos: Any, identity: Identity) -> Any:
    """A participant authenticated with ``identity``, carrying its :class:`Scope`."""
    from cyclonedds.core import DDSException
    from cyclonedds.domain import DomainParticipant

    try:
        participant = DomainParticipant(domain_id, qos=qos)
    except DDSException as exc:
        raise NotPermittedError(
            f"DDS Security refused identity {identity.path}: its certificate, key, governance or "
            f"permissions do not verify (signed by the keystore's CAs? expired? domain {domain_id} "
            f"granted?); run with CYCLONEDDS_URI tracing for details ({exc})"
        ) from exc
    participant._paramdds_scope = Scope(participant, identity)  # type: ignore[attr-defined]
    return participant
