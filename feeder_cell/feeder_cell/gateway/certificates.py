"""The gateway's own certificate: made on first start when a Basic256Sha256 policy is served without one.

A self-signed application instance certificate (OPC 10000-6, 6.2.2): RSA 2048 with SHA-256 (what
Basic256Sha256 asks for), the server's ApplicationUri as the SubjectAltName URI (clients compare it with
the server's description), the endpoint's host and this machine's name as DNS names or IP addresses, and
the key usages of both a server and a client. It is written once into ``pki_dir`` and reused on every
later start, so that a client that trusted it once keeps trusting it.

ROS-free; every error names the parameter pki_dir.
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import socket
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import rsa
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from feeder_planner.errors import InputError

__all__ = [
    "CERTIFICATE_NAME",
    "KEY_NAME",
    "VALID_DAYS",
    "ServerCertificate",
    "default_pki_dir",
    "ensure_certificate",
    "thumbprints",
]

CERTIFICATE_NAME = "gateway_cert.der"
KEY_NAME = "gateway_key.pem"
VALID_DAYS = 3650  # a cell lives for years; a client that pinned the certificate should not see it change
_FIELD = "parameter pki_dir"


@dataclass(frozen=True)
class ServerCertificate:
    """The certificate and key files the server loads, and whether this start made them."""

    certificate_file: str
    private_key_file: str
    created: bool
    sha1: str
    sha256: str


def default_pki_dir() -> Path:
    """Where the certificate goes when pki_dir is empty: ``$ROS_HOME/feeder/opcua_pki`` (``~/.ros``)."""
    ros_home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return Path(ros_home) / "feeder" / "opcua_pki"


def thumbprints(der: bytes) -> tuple[str, str]:
    """Return the SHA-1 (OPC UA's thumbprint) and SHA-256 fingerprints of a DER certificate, hex, colons."""

    def hexed(algorithm: hashes.HashAlgorithm) -> str:
        digest = hashes.Hash(algorithm)
        digest.update(der)
        return digest.finalize().hex(":").upper()

    return hexed(hashes.SHA1()), hexed(hashes.SHA256())  # noqa: S303 - SHA-1 is what OPC UA shows


def _alt_names(application_uri: str, host: str) -> list[x509.GeneralName]:
    names: list[x509.GeneralName] = [x509.UniformResourceIdentifier(application_uri)]
    hosts = [host, socket.gethostname(), "localhost"]
    seen: set[str] = set()
    for name in hosts:
        if not name or name in seen:
            continue
        seen.add(name)
        try:
            address = ipaddress.ip_address(name)
        except ValueError:
            names.append(x509.DNSName(name))
            continue
        if not address.is_unspecified:  # 0.0.0.0 is where it listens, never what a client dials
            names.append(x509.IPAddress(address))
    return names


def _make(application_uri: str, host: str) -> tuple[bytes, bytes]:
    key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
    subject = x509.Name(
        [
            x509.NameAttribute(NameOID.COMMON_NAME, "feeder opcua_gateway"),
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, "feeder"),
        ]
    )
    now = datetime.datetime.now(datetime.timezone.utc)
    public = key.public_key()
    certificate = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(subject)
        .public_key(public)
        .serial_number(x509.random_serial_number())
        # An hour back: a client whose clock is a little behind must not read it as not yet valid.
        .not_valid_before(now - datetime.timedelta(hours=1))
        .not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
        .add_extension(x509.SubjectAlternativeName(_alt_names(application_uri, host)), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=True,
                content_commitment=True,
                key_encipherment=True,
                data_encipherment=True,
                key_agreement=False,
                # Self-signed: it verifies its own signature, which OPC 10000-6 allows it to say.
                key_cert_sign=True,
                crl_sign=False,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(
            x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
            critical=False,
        )
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(public), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(public), critical=False)
        .sign(key, hashes.SHA256())
    )
    pem = key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )
    return certificate.public_bytes(serialization.Encoding.DER), pem


def _check_existing(certificate_file: Path, application_uri: str) -> bytes:
    """Read a certificate made before; refuse one that no longer fits rather than serve it."""
    der = certificate_file.read_bytes()
    try:
        certificate = x509.load_der_x509_certificate(der)
        uris = certificate.extensions.get_extension_for_class(
            x509.SubjectAlternativeName
        ).value.get_values_for_type(x509.UniformResourceIdentifier)
    except (ValueError, x509.ExtensionNotFound) as error:
        raise InputError(_FIELD, f"{certificate_file} is not a gateway certificate ({error})") from None
    if application_uri not in uris:
        raise InputError(
            _FIELD,
            f"{certificate_file} is for {', '.join(uris) or 'no application URI'}, not {application_uri}; "
            "remove it and its key to have a new one made",
        )
    if certificate.not_valid_after_utc <= datetime.datetime.now(datetime.timezone.utc):
        raise InputError(
            _FIELD,
            f"{certificate_file} expired on {certificate.not_valid_after_utc:%Y-%m-%d}; "
            "remove it and its key to have a new one made",
        )
    return der


def ensure_certificate(pki_dir: str, application_uri: str, host: str) -> ServerCertificate:
    """Return the certificate in ``pki_dir`` (empty: ``default_pki_dir()``), making it on first use."""
    folder = Path(pki_dir).expanduser() if pki_dir else default_pki_dir()
    certificate_file, key_file = folder / CERTIFICATE_NAME, folder / KEY_NAME
    have = [p.is_file() for p in (certificate_file, key_file)]
    try:
        if all(have):
            if not os.access(key_file, os.R_OK):
                raise InputError(_FIELD, f"cannot read {key_file}")
            der = _check_existing(certificate_file, application_uri)
            created = False
        elif any(have):
            present, missing = (certificate_file, key_file) if have[0] else (key_file, certificate_file)
            raise InputError(
                _FIELD, f"has {present.name} without {missing.name}; remove {present} to have both made anew"
            )
        else:
            folder.mkdir(mode=0o700, parents=True, exist_ok=True)
            der, pem = _make(application_uri, host)
            # The key is written first, readable by this user only, and each file appears whole (rename),
            # so an interrupted start never leaves a certificate whose key is missing or cut short.
            for path, data, mode in ((key_file, pem, 0o600), (certificate_file, der, 0o644)):
                partial = path.with_name(path.name + ".partial")
                descriptor = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
                with os.fdopen(descriptor, "wb") as out:
                    out.write(data)
                os.replace(partial, path)
            created = True
    except OSError as error:
        raise InputError(_FIELD, f"cannot use {folder}: {error.strerror or error}") from None
    sha1, sha256 = thumbprints(der)
    return ServerCertificate(str(certificate_file), str(key_file), created, sha1, sha256)
