"""The server's channel and identity security, applied to an asyncua server before it starts.

The policies offered, the login tokens, the server's certificate and how a client's certificate is
checked.

Its own module because these are the settings a factory network's security review reads, in one place,
apart from the address space and the values. Applied once, on the loop, before the server starts.
"""

from __future__ import annotations

from pathlib import Path

from asyncua import Server, ua
from asyncua.crypto.truststore import TrustStore
from asyncua.crypto.validator import CertificateValidator, CertificateValidatorOptions

from feeder_cell.gateway.config import SecurityConfig
from feeder_cell.gateway.users import Users

__all__ = ["POLICY_TYPES", "secure"]

POLICY_TYPES = {
    "None": ua.SecurityPolicyType.NoSecurity,
    "Basic256Sha256_Sign": ua.SecurityPolicyType.Basic256Sha256_Sign,
    "Basic256Sha256_SignAndEncrypt": ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
}


async def secure(server: Server, security: SecurityConfig, users: Users | None) -> None:
    """Set the server's policies, identity tokens, certificate and key, and client certificate validator."""
    server.set_security_policy([POLICY_TYPES[p] for p in security.policies])
    tokens: list[type] = []
    if security.allow_anonymous:
        tokens.append(ua.AnonymousIdentityToken)
    if users is not None:
        tokens.append(ua.UserNameIdentityToken)
    server.set_identity_tokens(tokens)
    if security.certificate_file:
        await server.load_certificate(security.certificate_file)
        await server.load_private_key(security.private_key_file)
    if security.trusted_certificates_dir:
        store = TrustStore([Path(security.trusted_certificates_dir)], [])
        await store.load()
        options = CertificateValidatorOptions.TRUSTED_VALIDATION | CertificateValidatorOptions.PEER_CLIENT
        server.set_certificate_validator(CertificateValidator(options, store))
    else:
        # No trust list: any issuer opens a channel, but a certificate is still checked for itself
        # (OPC 10000-4, 6.1.3): its validity period and that its URI is the client's ApplicationUri.
        options = CertificateValidatorOptions.BASIC_VALIDATION | CertificateValidatorOptions.PEER_CLIENT
        server.set_certificate_validator(CertificateValidator(options))
