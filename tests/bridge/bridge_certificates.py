"""Certificates for the bridge's TLS tests, made in the test's own folder (no private key is committed)."""

from __future__ import annotations

import datetime as dt
import ipaddress
from pathlib import Path


def make_certificate(
    folder: Path,
    name: str,
    addresses: tuple[str, ...],
    encrypt_key: bool = False,
    valid_days: tuple[int, int] = (-1, 30),
) -> tuple[Path, Path]:
    """Write a self-signed server certificate for ``addresses`` and its key; return (certificate, key).

    ``valid_days``: its validity, from and to, in days from now. The addresses are IP subject alternative
    names: a client checks the one it connected to against them.
    """
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    key = ec.generate_private_key(ec.SECP256R1())  # quick to make, unlike RSA on a loaded machine
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"feeder bridge test {name}")])
    now = dt.datetime.now(dt.timezone.utc)
    certificate = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now + dt.timedelta(days=valid_days[0]))
        .not_valid_after(now + dt.timedelta(days=valid_days[1]))
        .add_extension(
            x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address(a)) for a in addresses]),
            critical=False,
        )
        # A CA of itself, so that a client can trust it directly (NODE_EXTRA_CA_CERTS, an OS store).
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .sign(key, hashes.SHA256())
    )
    cert_file, key_file = folder / f"{name}_cert.pem", folder / f"{name}_key.pem"
    cert_file.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    encryption = (
        serialization.BestAvailableEncryption(b"secret") if encrypt_key else serialization.NoEncryption()
    )
    key_file.write_bytes(
        key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, encryption)
    )
    return cert_file, key_file
