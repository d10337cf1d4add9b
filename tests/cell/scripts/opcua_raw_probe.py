"""What the gateway's server answers to sessions a careful client would never ask for; prints one JSON line.

node-opcua refuses on its own side to send an anonymous token no endpoint lists or to use a None
endpoint that is not offered, so those refusals would be the client's. This probe sends them anyway with
asyncua's low-level calls, so that a refusal here is the server's: an anonymous session over
SignAndEncrypt, and a session (with the right password, and anonymous) on a None secure channel.

Usage: python opcua_raw_probe.py URL USER PASSWORD FOLDER (FOLDER: where the probe's certificate goes).
"""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

from asyncua import Client, ua

from feeder_cell.gateway.certificates import ensure_certificate

PRODUCT_NAME = "i=2261"  # Server/ServerStatus/BuildInfo/ProductName
CLIENT_URI = "urn:feeder:test:raw-probe"


def _refusal(error: BaseException) -> str:
    return f"{type(error).__name__}: {error}".splitlines()[0]


async def secure_anonymous(url: str, folder: Path) -> dict[str, object]:
    """Open a SignAndEncrypt channel and activate an anonymous session (asyncua sends it unlisted)."""
    made = ensure_certificate(str(folder), CLIENT_URI, "localhost")
    client = Client(url, timeout=10)
    client.application_uri = CLIENT_URI
    await client.set_security_string(
        f"Basic256Sha256,SignAndEncrypt,{made.certificate_file},{made.private_key_file}"
    )
    try:
        await client.connect()
    except Exception as error:  # noqa: BLE001 - the refusal is the result
        return {"ok": False, "error": _refusal(error)}
    try:
        return {"ok": True, "product_name": await client.get_node(PRODUCT_NAME).read_value()}
    finally:
        await client.disconnect()


async def none_channel(
    url: str, token: ua.UserNameIdentityToken | ua.AnonymousIdentityToken
) -> dict[str, object]:
    """Open a None channel, create a session on it and activate it with ``token``; then read."""
    client = Client(url, timeout=10)
    await client.connect_socket()
    try:
        await client.send_hello()
        await client.open_secure_channel()
        params = ua.CreateSessionParameters()
        params.ClientDescription = ua.ApplicationDescription()
        params.ClientDescription.ApplicationUri = CLIENT_URI
        params.ClientDescription.ApplicationType = ua.ApplicationType.Client
        params.EndpointUrl = url
        params.SessionName = "raw-probe"
        params.RequestedSessionTimeout = 60_000
        params.ClientNonce = b"\x01" * 32
        try:
            await client.uaclient.create_session(params)
        except Exception as error:  # noqa: BLE001
            return {"ok": False, "stage": "create_session", "error": _refusal(error)}
        activate = ua.ActivateSessionParameters()
        activate.LocaleIds = ["en"]
        activate.UserIdentityToken = token
        try:
            await client.uaclient.activate_session(activate)
            value = await client.get_node(PRODUCT_NAME).read_value()
        except Exception as error:  # noqa: BLE001
            return {"ok": False, "stage": "activate_session", "error": _refusal(error)}
        return {"ok": True, "product_name": value}
    finally:
        client.disconnect_socket()


async def main(url: str, user: str, password: str, folder: Path) -> dict[str, object]:
    named = ua.UserNameIdentityToken()
    named.PolicyId, named.UserName, named.Password = "username", user, password.encode()
    anonymous = ua.AnonymousIdentityToken()
    anonymous.PolicyId = "anonymous"
    return {
        "secure_anonymous": await secure_anonymous(url, folder),
        "none_user": await none_channel(url, named),
        "none_anonymous": await none_channel(url, anonymous),
    }


if __name__ == "__main__":
    address, name, secret, where = sys.argv[1:5]
    print(json.dumps(asyncio.run(main(address, name, secret, Path(where)))))
