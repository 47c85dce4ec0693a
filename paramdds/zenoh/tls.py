"""Certificates for Zenoh's mutual TLS, issued by a ``paramdds keystore``'s identity CA.

``issue(keystore, name, hosts, out)`` writes ``out/ca.pem``, ``out/cert.pem`` and
``out/key.pem`` (mode 0600): an ECDSA P-256 certificate whose common name is ``name``
(what Zenoh's access control matches with ``cert_common_names``) and whose subject
alternative names are ``hosts`` (IP addresses or DNS names this side is dialled at; a
router needs them, Zenoh checks them on connect), signed by the keystore's
``ca/identity_ca.pem``. Any PEM files from another CA work the same way.
``certificate_name(cert)`` reads a certificate's common name back (the name a remote
client claims as who changed a parameter).
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import os
import re
from collections.abc import Sequence
from pathlib import Path

from ..errors import ParamddsError

_NAME = re.compile(r"[A-Za-z0-9_.\-]{1,64}")


def issue(keystore: Path, name: str, hosts: Sequence[str], out: Path, *, days: int = 825) -> Path:
    """Issue a TLS certificate for ``name`` from ``keystore``'s identity CA into ``out``."""
    try:
        from cryptography import x509
        from cryptography.hazmat.primitives import hashes, serialization
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID
    except ImportError as exc:
        raise ParamddsError(f"issuing certificates needs the secure extra (cryptography): {exc}") from None
    if not _NAME.fullmatch(name):
        raise ParamddsError(f"certificate name {name!r}: 1-64 letters, digits, '_', '.', '-'")
    ca_cert_file = keystore / "ca" / "identity_ca.pem"
    ca_key_file = keystore / "ca" / "identity_ca.key.pem"
    if not ca_cert_file.is_file() or not ca_key_file.is_file():
        raise ParamddsError(
            f"{keystore} is not a keystore (no ca/identity_ca.pem): run 'paramdds keystore init'"
        )
    ca_cert = x509.load_pem_x509_certificate(ca_cert_file.read_bytes())
    ca_key = serialization.load_pem_private_key(ca_key_file.read_bytes(), password=None)
    sans: list[x509.GeneralName] = []
    for host in hosts:
        try:
            sans.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            sans.append(x509.DNSName(host))
    key = ec.generate_private_key(ec.SECP256R1())
    now = dt.datetime.now(dt.timezone.utc)
    builder = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
        .issuer_name(ca_cert.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=days))
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(
            x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
            critical=False,
        )
    )
    if sans:
        builder = builder.add_extension(x509.SubjectAlternativeName(sans), critical=False)
    cert = builder.sign(ca_key, hashes.SHA256())  # type: ignore[arg-type]
    out.mkdir(parents=True, exist_ok=True)
    (out / "ca.pem").write_bytes(ca_cert.public_bytes(serialization.Encoding.PEM))
    (out / "cert.pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_file = out / "key.pem"
    fd = os.open(key_file, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(
            key.private_bytes(
                serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
            )
        )
    return out


def certificate_name(cert_file: Path) -> str | None:
    """The common name of the certificate in ``cert_file`` (PEM); None when the file is not
    one, has no common name, or the secure extra (cryptography) is not installed."""
    try:
        from cryptography import x509
        from cryptography.x509.oid import NameOID
    except ImportError:
        return None
    try:
        cert = x509.load_pem_x509_certificate(cert_file.read_bytes())
    except (OSError, ValueError):
        return None
    names = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    return str(names[0].value) if names else None
