"""One identity directory (``--identity DIR`` / ``PARAMDDS_IDENTITY``): everything else is derived.

:func:`load_identity` reads ``DIR/paramdds.json`` (name, role, node globs, written by
:mod:`.keystore`) and checks the files DDS needs are there; :meth:`Identity.security_xml`
is the Cyclone ``<Security>`` element for them. The grants in ``paramdds.json`` only
choose which partitions this process reads (:mod:`paramdds.dds.transport`); what it may do is decided
by DDS from the signed ``permissions.p7s``, on this side and on every peer.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path

from ..errors import ErrorCode, ParamddsError
from .roles import GOVERNANCE_MAX_DOMAIN, META, ROLES

__all__ = ["IDENTITY_ENV", "Identity", "identity_from_env", "load_identity", "require_secure_library"]

IDENTITY_ENV = "PARAMDDS_IDENTITY"
_FILES = ("cert.pem", "key.pem", "identity_ca.pem", "permissions_ca.pem", "governance.p7s", "permissions.p7s")
HOW_TO_INSTALL = (
    "build one with 'paramdds keystore install --source <cyclonedds-11.0.1 sources> --prefix <dir>' "
    "(see docs/secure.md), or point CYCLONEDDS_HOME at a Cyclone DDS 11.0.1 built with -DENABLE_SECURITY=ON"
)


@dataclass(frozen=True)
class Identity:
    """A loaded identity: its files, its role and the node-id globs it was granted."""

    path: Path
    name: str
    role: str
    nodes: tuple[str, ...]

    def security_xml(self) -> str:
        """The ``<Security>`` element of a Cyclone ``<Domain>`` for this identity."""

        def uri(name: str) -> str:
            return "file:" + str(self.path / name)

        return (
            "<Security><Authentication>"
            f"<IdentityCertificate>{uri('cert.pem')}</IdentityCertificate>"
            f"<IdentityCA>{uri('identity_ca.pem')}</IdentityCA>"
            f"<PrivateKey>{uri('key.pem')}</PrivateKey>"
            "</Authentication><AccessControl>"
            f"<Governance>{uri('governance.p7s')}</Governance>"
            f"<PermissionsCA>{uri('permissions_ca.pem')}</PermissionsCA>"
            f"<Permissions>{uri('permissions.p7s')}</Permissions>"
            "</AccessControl></Security>"
        )

    def security_config(self, domain_id: int) -> str:
        """For :func:`paramdds.dds.participant.make_participant`: check the domain id and the
        library (a secure Cyclone build), then the ``<Security>`` element."""
        check_domain(domain_id)
        require_secure_library()
        return self.security_xml()

    def covers(self, node: str) -> bool:
        """Whether ``node`` matches one of the granted globs (DDS decides; this words errors)."""
        return any(fnmatchcase(node, g) for g in self.nodes)


def load_identity(path: str | os.PathLike[str]) -> Identity:
    """Read an identity directory; a missing or incomplete one is a clear error."""
    root = Path(path).expanduser().resolve()
    meta_file = root / META
    if not meta_file.is_file():
        raise ParamddsError(
            f"{root} is not a paramdds identity (no {META}): make one with "
            "'paramdds keystore add KEYSTORE NAME --role ROLE --nodes GLOB'",
            code=ErrorCode.FILE_FORMAT,
        )
    missing = [f for f in _FILES if not (root / f).is_file()]
    if missing:
        raise ParamddsError(f"identity {root} lacks {', '.join(missing)}", code=ErrorCode.FILE_FORMAT)
    try:
        meta = json.loads(meta_file.read_text())
        role, nodes, name = str(meta["role"]), tuple(str(n) for n in meta["nodes"]), str(meta["name"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ParamddsError(f"{meta_file}: unreadable ({exc})", code=ErrorCode.FILE_FORMAT) from exc
    if role not in ROLES:
        raise ParamddsError(f"{meta_file}: unknown role {role!r}", code=ErrorCode.FILE_FORMAT)
    return Identity(root, name, role, nodes)


def identity_from_env(explicit: str | None, environ: dict[str, str] | None = None) -> Identity | None:
    """The identity named by ``--identity`` or ``PARAMDDS_IDENTITY``, or None (not secure)."""
    env = os.environ if environ is None else environ
    path = explicit or env.get(IDENTITY_ENV, "").strip()
    return load_identity(path) if path else None


def check_domain(domain_id: int) -> None:
    if domain_id > GOVERNANCE_MAX_DOMAIN:
        raise ParamddsError(
            f"secure mode works on domain ids 0..{GOVERNANCE_MAX_DOMAIN} (Cyclone's governance "
            f"refuses more), got {domain_id}",
            code=ErrorCode.INVALID_VALUE,
        )


def require_secure_library() -> None:
    """Fail clearly when the loaded Cyclone library has no DDS Security plugins."""
    from cyclonedds.internal import load_cyclonedds

    lib = load_cyclonedds()
    where = Path(getattr(lib, "_name", "") or "")
    if not (where.parent / "libdds_security_auth.so").is_file():
        raise ParamddsError(
            f"secure mode needs Cyclone DDS built with security, and {where} has none (the PyPI "
            f"wheels are built without it): {HOW_TO_INSTALL}",
            code=ErrorCode.INTERNAL,  # exit 4: this installation cannot do it
        )
