"""The bridge's security settings, checked before anything starts: TLS files, and who may act off loopback.

The rules are the OPC UA gateway's (``gateway.config.check_security``): on a loopback address anything
goes, and today's defaults stand (plain ``ws://``, every capability). Any other address (``0.0.0.0`` and
host names included: they are not provably loopback) reaches a factory network, so by default it needs
TLS and serves nothing that acts; plain ``ws://`` needs ``--allow-insecure-remote`` and control
(services, parameter sets, client publishing) ``--allow-remote-control``, each explicit and a WARNING
at every start. Every refusal is an :class:`InputError` naming the option: one line, exit 2.

Light to import (no ROS, no ``cryptography`` until a certificate is read).
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import ssl
from dataclasses import dataclass

from feeder_planner.errors import InputError

__all__ = ["BridgeSecurity", "check_bridge_security"]


@dataclass(frozen=True)
class BridgeSecurity:
    """Checked settings: the TLS context (None: plain ws://) and the opt-outs a start logs."""

    tls: ssl.SSLContext | None
    remote: bool
    warnings: tuple[str, ...]

    @property
    def scheme(self) -> str:
        """The URL scheme clients connect with: wss with TLS, else ws."""
        return "wss" if self.tls is not None else "ws"


def is_loopback(host: str) -> bool:
    """Whether the host is a loopback address (``localhost`` counts; any other name does not).

    The gateway's rule (``gateway.config.is_loopback``), repeated because that module pulls in asyncua.
    """
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name that might resolve anywhere: not provably loopback


def _read(path: str, option: str) -> bytes:
    if not os.path.isfile(path) or not os.access(path, os.R_OK):
        raise InputError(option, f"cannot read {path!r}")
    with open(path, "rb") as file:
        return file.read()


def tls_context(certificate_file: str, key_file: str) -> ssl.SSLContext:
    """Return a server TLS context for the PEM pair; a bad file is an InputError naming its option.

    The files are parsed with ``cryptography`` first because OpenSSL's own errors ("[SSL] PEM lib")
    say neither which file is wrong nor how.
    """
    from cryptography import x509
    from cryptography.exceptions import UnsupportedAlgorithm
    from cryptography.hazmat.primitives import serialization

    certificate_pem, key_pem = _read(certificate_file, "--tls-cert"), _read(key_file, "--tls-key")
    try:
        certificate = x509.load_pem_x509_certificate(certificate_pem)
    except ValueError:
        raise InputError("--tls-cert", f"{certificate_file!r} is not a PEM certificate") from None
    # Every client would refuse it, each with its own words: say it once, here, naming the dates.
    now = datetime.datetime.now(datetime.timezone.utc)
    start, end = certificate.not_valid_before_utc, certificate.not_valid_after_utc
    if not start <= now <= end:
        when = (
            f"expired on {end:%Y-%m-%d %H:%M} UTC"
            if now > end
            else f"is valid only from {start:%Y-%m-%d %H:%M} UTC"
        )
        raise InputError("--tls-cert", f"{certificate_file!r} {when}")
    try:
        key = serialization.load_pem_private_key(key_pem, password=None)
    except TypeError:  # the key is encrypted: nobody is there to type its passphrase
        raise InputError("--tls-key", f"{key_file!r} is encrypted; give an unencrypted key") from None
    except (ValueError, UnsupportedAlgorithm):
        raise InputError("--tls-key", f"{key_file!r} is not a PEM private key") from None
    pem, public = serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
    if key.public_key().public_bytes(pem, public) != certificate.public_key().public_bytes(pem, public):
        raise InputError("--tls-key", f"{key_file!r} does not match the certificate of --tls-cert")
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    try:
        context.load_cert_chain(certificate_file, key_file)
    except ssl.SSLError as error:  # parsed above, yet refused by OpenSSL (e.g. a too weak key)
        raise InputError("--tls-cert", f"OpenSSL refuses {certificate_file!r}: {error}") from None
    return context


def check_bridge_security(
    address: str,
    certificate_file: str | None,
    key_file: str | None,
    read_only: bool,
    allow_insecure_remote: bool,
    allow_remote_control: bool,
) -> BridgeSecurity:
    """Check the options against each other and the address; every refusal names the option."""
    if bool(certificate_file) != bool(key_file):
        # One file alone is a half-configured server, never silently served in plain text.
        given, missing = ("--tls-cert", "--tls-key") if certificate_file else ("--tls-key", "--tls-cert")
        raise InputError(missing, f"is required with {given}")
    tls = tls_context(certificate_file, key_file) if certificate_file and key_file else None
    remote = not is_loopback(address)
    warnings: list[str] = []
    if remote and tls is None:
        if not allow_insecure_remote:
            raise InputError(
                "--tls-cert",
                f"{address} is not a loopback address: serve wss:// with --tls-cert FILE --tls-key FILE, or "
                "give --allow-insecure-remote to serve plain ws:// to the network explicitly",
            )
        warnings.append(
            f"--allow-insecure-remote: plain ws:// on {address}: anyone on the network can read the "
            "cell's traffic" + ("" if read_only else " and forge what clients send")
        )
    if remote and not read_only:
        if not allow_remote_control:
            raise InputError(
                "--allow-remote-control",
                f"{address} is not a loopback address, and clients there could call the cell's services, "
                "set parameters and publish: give --read-only to serve without control, or "
                "--allow-remote-control to allow it explicitly",
            )
        warnings.append(
            f"--allow-remote-control: any client that reaches {address} can call the cell's services, set "
            "its parameters and publish on client topics"
        )
    return BridgeSecurity(tls, remote, tuple(warnings))
