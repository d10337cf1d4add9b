"""Password logins without ROS: a GatewayServer in this process, asyncua clients logging in.

The password check runs off the server's event loop (a session's reads go on while a check is held), an
unknown user name costs one PBKDF2 check of the users' iteration count like a known one, failed logins
lock the address and the name out by the documented rule and the right password works once the lockout
is over, and every login is one log line with address, user, certificate and outcome, never the password
(docs/cell.md: Logins). The time a refusal takes is bench/bench_gateway.py's (the login rows).
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import socket
import threading
import time
from pathlib import Path

import pytest
from asyncua import Client, ua
from asyncua.ua.uaerrors import BadUserAccessDenied, UaError

from feeder_cell.gateway.config import DeviceEntry, Endpoint, SecurityConfig
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Goal
from feeder_cell.gateway.users import Users, hash_password, load_users

ARM = DeviceEntry("throwing_arm", "/l/throwing_arm")
PASSWORD = "line-7"
ROUNDS = 20_000


class _NoCalls:
    async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
        return "BadNotSupported", "no ROS here"


def _port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _gateway(users: Users, failures: int = 5, lockout: float = 30.0) -> GatewayServer:
    port = _port()
    url = f"opc.tcp://127.0.0.1:{port}"
    security = SecurityConfig(("None",), "", "", False, "u", login_failures=failures, login_lockout=lockout)
    return GatewayServer(Endpoint(url, "127.0.0.1", port), security, users, (ARM,), _NoCalls())


def _users(tmp_path: Path) -> Users:
    path = tmp_path / "users.yaml"
    path.write_text(f'users:\n  plc: {{role: Operator, hash: "{hash_password(PASSWORD, ROUNDS)}"}}\n')
    return load_users(str(path))


async def _login(url: str, user: str, password: str) -> Client | None:
    """Return a connected client, or None when the login is refused."""
    client = Client(url, timeout=10)
    client.set_user(user)
    client.set_password(password)
    try:
        await client.connect()
    except (BadUserAccessDenied, UaError):
        return None
    return client


def test_an_unknown_user_is_checked_like_a_known_one(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    users = _users(tmp_path)
    rounds: list[int] = []
    real = hashlib.pbkdf2_hmac

    def counted(name: str, password: bytes, salt: bytes, iterations: int) -> bytes:
        rounds.append(iterations)
        return real(name, password, salt, iterations)

    monkeypatch.setattr(hashlib, "pbkdf2_hmac", counted)
    assert not users.check("plc", "wrong")
    assert not users.check("nobody", PASSWORD)
    assert not users.check("nobody", None) and not users.check(None, None)
    assert users.check("plc", PASSWORD)
    # One check each, of the users' iteration count (the dummy's is made once, first).
    checks = [n for n in rounds if n == ROUNDS]
    assert len(checks) >= 5 and set(rounds) == {ROUNDS}, rounds


def test_the_password_check_runs_off_the_loop_so_other_sessions_go_on(tmp_path: Path) -> None:
    users = _users(tmp_path)
    held, entered = threading.Event(), threading.Event()
    check = users.check

    def slow_check(name: str | None, password: str | None) -> bool:
        entered.set()
        held.wait(20)  # released by the test once the other session's read came back
        return check(name, password)

    object.__setattr__(users, "check", slow_check)

    async def main() -> None:
        gateway = _gateway(users)
        await gateway.start()
        url = gateway.endpoint.url
        try:
            held.set()  # the watcher's own login goes through at once
            watcher = await _login(url, "plc", PASSWORD)
            assert watcher is not None
            held.clear()
            entered.clear()
            storm = asyncio.ensure_future(_login(url, "plc", "wrong"))
            await asyncio.to_thread(entered.wait, 10)
            assert entered.is_set(), "the login never reached its check"
            # The check is held in its thread: were it on the loop, this read could not be answered.
            value = await asyncio.wait_for(watcher.nodes.server_state.read_value(), 10)
            assert value == ua.ServerState.Running
            held.set()
            assert await storm is None
            await watcher.disconnect()
        finally:
            held.set()
            await gateway.stop()

    asyncio.run(main())


def test_failed_logins_lock_out_then_the_right_password_works_and_each_is_logged(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    lockout = 1.5

    async def main() -> None:
        gateway = _gateway(_users(tmp_path), failures=3, lockout=lockout)
        await gateway.start()
        url = gateway.endpoint.url
        try:
            for _ in range(4):  # the fourth failure is past login_failures 3: it locks out
                assert await _login(url, "plc", "wrong") is None
            locked_at = time.monotonic()
            assert await _login(url, "plc", PASSWORD) is None  # locked out: refused unchecked
            assert gateway.logins is not None and gateway.logins.counts["logins_locked_out"] == 1
            await asyncio.sleep(max(0.0, lockout + 0.2 - (time.monotonic() - locked_at)))
            client = await _login(url, "plc", PASSWORD)
            assert client is not None, "the right password after the lockout"
            await client.disconnect()
            # A success reset the counts: one failure now does not lock out.
            assert await _login(url, "plc", "wrong") is None
            client = await _login(url, "plc", PASSWORD)
            assert client is not None
            await client.disconnect()
            assert gateway.logins.counts == {
                "logins_accepted": 2,
                "logins_refused": 5,
                "logins_locked_out": 1,
            }
        finally:
            await gateway.stop()

    with caplog.at_level(logging.INFO, logger="opcua_gateway"):
        asyncio.run(main())
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("login from")]
    assert len(lines) == 8, lines
    assert all("login from 127.0.0.1 as plc (certificate none): " in line for line in lines), lines
    assert sum("accepted" in line for line in lines) == 2
    assert sum("wrong user name or password" in line for line in lines) == 5
    assert "address 127.0.0.1 and user plc locked out for 1.5 s" in lines[3], lines
    assert "refused: locked out for" in lines[4], lines
    assert not any(PASSWORD in line for line in lines)
