"""The keystore: CAs, governance and role identities for secure mode (``paramdds keystore``).

Layout of a keystore directory::

    ca/identity_ca.pem      ca/identity_ca.key.pem      (signs identity certificates)
    ca/permissions_ca.pem   ca/permissions_ca.key.pem   (signs governance and permissions)
    governance.xml          governance.p7s              (the signed copy is what DDS reads)
    identities/NAME/        one directory per identity, self-contained: pass it to --identity
        cert.pem key.pem identity_ca.pem permissions_ca.pem governance.p7s
        permissions.xml permissions.p7s paramdds.json

Keys are ECDSA P-256, written with mode 0600 (directories holding them 0700).
Certificates are X.509 and the documents S/MIME (PKCS#7, detached, text) signed
with the well-kept ``cryptography`` library; nothing here implements cryptography.

The governance (one for the whole domain range 0..230, Cyclone refuses more):
participants must authenticate and be allowed to join (``allow_unauthenticated_participants``
false, ``enable_join_access_control`` true); endpoint discovery and liveliness are
encrypted; every topic has read and write access control, and its submessages and
payloads are encrypted (``metadata_protection_kind`` and ``data_protection_kind``
ENCRYPT); whole RTPS messages are signed (``rtps_protection_kind`` SIGN). These are the
defaults SROS2 generates for ROS 2.

Roles (each grant lists the node-id globs an identity is given; partitions carry node
ids, see :mod:`paramdds.dds.transport`):

========  ==========================================================================
server    publish state and replies, read requests (and state), for its globs
operator  publish get/list/set requests, read replies and state, for its globs
viewer    publish get/list requests, read their replies and state: never set
admin     everything, for its globs (``*``: a full-rights identity)
========  ==========================================================================
"""

from __future__ import annotations

import datetime as dt
import json
import os
import re
import shutil
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

from .identity import Identity
from .roles import GOVERNANCE_MAX_DOMAIN, META, ROLES

__all__ = [
    "GOVERNANCE_MAX_DOMAIN",
    "ROLES",
    "add_identity",
    "governance_xml",
    "init_keystore",
    "permissions_xml",
]

_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")
_GLOB = re.compile(r"[A-Za-z0-9_/*?]{1,255}")
_ORG = "paramdds"


class KeystoreError(Exception):
    """Bad keystore input or state; the message says what to fix."""


def _crypto() -> Any:
    try:
        from cryptography import x509
    except ImportError as exc:
        raise KeystoreError(
            "the keystore needs the secure extra (cryptography not installed): "
            "pip install -e '.[secure]' in the paramdds checkout"
        ) from exc
    return x509


def _write_private(path: Path, data: bytes) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.chmod(path, 0o600)


def _private_dir(path: Path) -> None:
    """Create ``path`` (and its parents) with mode 0700, whatever the umask."""
    path.mkdir(parents=True, mode=0o700)
    os.chmod(path, 0o700)


def _new_key() -> Any:
    from cryptography.hazmat.primitives.asymmetric import ec

    return ec.generate_private_key(ec.SECP256R1())


def _key_pem(key: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization

    return key.private_bytes(  # type: ignore[no-any-return]
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )


def _cert_pem(cert: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization

    return cert.public_bytes(serialization.Encoding.PEM)  # type: ignore[no-any-return]


def _subject(common_name: str) -> Any:
    x509 = _crypto()
    from cryptography.x509.oid import NameOID

    return x509.Name(
        [
            x509.NameAttribute(NameOID.COMMON_NAME, common_name),
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, _ORG),
        ]
    )


def _certificate(subject: Any, key: Any, issuer: Any, issuer_key: Any, days: int, *, ca: bool) -> Any:
    x509 = _crypto()
    from cryptography.hazmat.primitives import hashes

    now = dt.datetime.now(dt.timezone.utc)
    builder = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=days))
        .add_extension(x509.BasicConstraints(ca=ca, path_length=None), critical=True)
    )
    return builder.sign(issuer_key, hashes.SHA256())


def _sign(document: bytes, cert: Any, key: Any) -> bytes:
    """S/MIME, detached, text: what the DDS Security access control plugin verifies."""
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.serialization import pkcs7

    return (
        pkcs7.PKCS7SignatureBuilder()
        .set_data(document)
        .add_signer(cert, key, hashes.SHA256())
        .sign(serialization.Encoding.SMIME, [pkcs7.PKCS7Options.Text, pkcs7.PKCS7Options.DetachedSignature])
    )


def _load_ca(root: Path, which: str) -> tuple[Any, Any]:
    x509 = _crypto()
    from cryptography.hazmat.primitives import serialization

    cert_file, key_file = root / "ca" / f"{which}.pem", root / "ca" / f"{which}.key.pem"
    if not cert_file.is_file() or not key_file.is_file():
        raise KeystoreError(
            f"{root} is not a keystore (no ca/{which}.pem): run 'paramdds keystore init {root}'"
        )
    cert = x509.load_pem_x509_certificate(cert_file.read_bytes())
    key = serialization.load_pem_private_key(key_file.read_bytes(), password=None)
    return cert, key


def governance_xml() -> str:
    """The governance document (see the module docstring for what it chooses)."""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>{GOVERNANCE_MAX_DOMAIN}</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"""


def _criteria(kind: str, topics: tuple[str, ...], globs: tuple[str, ...]) -> str:
    topic_lines = "".join(f"<topic>{escape(t)}</topic>" for t in topics)
    part_lines = "".join(f"<partition>{escape(g)}</partition>" for g in globs)
    return f"        <{kind}><topics>{topic_lines}</topics><partitions>{part_lines}</partitions></{kind}>\n"


def permissions_xml(subject: str, role: str, globs: tuple[str, ...], days: int) -> str:
    """One grant: the role's topics, in partitions matching the node-id globs; DENY otherwise."""
    publish, subscribe = ROLES[role]
    now = dt.datetime.now(dt.timezone.utc).replace(microsecond=0, tzinfo=None)
    start, end = now - dt.timedelta(minutes=5), now + dt.timedelta(days=days)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="{escape(subject)}">
      <subject_name>{escape(subject)}</subject_name>
      <validity><not_before>{start.isoformat()}</not_before><not_after>{end.isoformat()}</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>{GOVERNANCE_MAX_DOMAIN}</max></id_range></domains>
{_criteria("publish", publish, globs)}{_criteria("subscribe", subscribe, globs)}      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
"""


def init_keystore(root: Path, *, days: int = 3650) -> Path:
    """Create the two CAs and the signed governance in ``root`` (refuses an existing keystore)."""
    if (root / "ca").exists():
        raise KeystoreError(f"{root} already holds a keystore (ca/ exists)")
    ca_dir = root / "ca"
    _private_dir(ca_dir)
    for which, name in (
        ("identity_ca", "paramdds identity CA"),
        ("permissions_ca", "paramdds permissions CA"),
    ):
        key = _new_key()
        subject = _subject(name)
        cert = _certificate(subject, key, subject, key, days, ca=True)
        _write_private(ca_dir / f"{which}.key.pem", _key_pem(key))
        (ca_dir / f"{which}.pem").write_bytes(_cert_pem(cert))
    (root / "identities").mkdir(exist_ok=True)
    governance = governance_xml().encode()
    (root / "governance.xml").write_bytes(governance)
    cert, key = _load_ca(root, "permissions_ca")
    (root / "governance.p7s").write_bytes(_sign(governance, cert, key))
    return root


def check_globs(globs: list[str]) -> tuple[str, ...]:
    if not globs:
        raise KeystoreError("give at least one --nodes glob (for example 'robot1*', or '*' for every node)")
    for g in globs:
        if not _GLOB.fullmatch(g):
            raise KeystoreError(
                f"node glob {g!r}: use node-id characters (letters, digits, '_', '/') "
                "and the wildcards * and ?"
            )
    return tuple(dict.fromkeys(globs))


def add_identity(root: Path, name: str, role: str, globs: list[str], *, days: int = 825) -> Identity:
    """Issue identity ``name`` with ``role`` for the node ids matching ``globs`` (replaces one)."""
    if not _NAME.fullmatch(name):
        raise KeystoreError(f"identity name {name!r}: use 1-64 letters, digits, '_', '.', '-'")
    if role not in ROLES:
        raise KeystoreError(f"role {role!r}: choose one of {', '.join(ROLES)}")
    nodes = check_globs(globs)
    id_cert, id_key = _load_ca(root, "identity_ca")
    perm_cert, perm_key = _load_ca(root, "permissions_ca")
    out = root / "identities" / name
    shutil.rmtree(out, ignore_errors=True)
    _private_dir(out)
    key = _new_key()
    subject = _subject(name)
    cert = _certificate(subject, key, id_cert.subject, id_key, days, ca=False)
    _write_private(out / "key.pem", _key_pem(key))
    (out / "cert.pem").write_bytes(_cert_pem(cert))
    shutil.copyfile(root / "ca" / "identity_ca.pem", out / "identity_ca.pem")
    shutil.copyfile(root / "ca" / "permissions_ca.pem", out / "permissions_ca.pem")
    shutil.copyfile(root / "governance.p7s", out / "governance.p7s")
    document = permissions_xml(subject.rfc4514_string(), role, nodes, days).encode()
    (out / "permissions.xml").write_bytes(document)
    (out / "permissions.p7s").write_bytes(_sign(document, perm_cert, perm_key))
    meta = {"name": name, "role": role, "nodes": list(nodes), "subject": subject.rfc4514_string()}
    (out / META).write_text(json.dumps(meta, indent=2) + "\n")
    return Identity(out, name, role, nodes)
