"""Password logins that cost a stranger, not everyone: checks off the event loop, lockouts, one log line each.

asyncua checks a password inside ActivateSession on the server's event loop, so a PBKDF2 check (tens of
ms) stalled every other session, and a storm of wrong passwords stalled the PLC. Here:

- **Off the loop.** ``install`` wraps the server's message processing: an ActivateSession with a user
  name has its password checked in a worker thread of its own (``LoginGuard.check``: one thread, so a
  storm takes one core at most and the loop keeps the other) before asyncua's own activation, which takes
  the answer from ``ATTEMPT`` (``GatewayUsers.get_user``).
- **Same cost, known or not.** An unknown user is checked against a dummy hash of the users' iteration
  count (``Users.check``), so the refusal takes as long as a wrong password.
- **Lockout.** After ``failures`` consecutive failed logins from one client address, or for one user name,
  each further failure locks that address (or name) out for ``lockout`` s: its attempts are refused at
  once, without a check, until then. A success resets the address's and the name's count. Other addresses
  and names are not affected, and the right password works again once the lockout is over.
- **Logged.** Every login, accepted or refused, is one line with the client's address, the user name,
  the client certificate's SHA-1 thumbprint and the outcome, never the password; ``counts`` go to the
  gateway's /diagnostics entry.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextvars
import hashlib
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast

from asyncua import ua
from asyncua.common.connection import SecureConnection
from asyncua.server.uaprocessor import UaProcessor
from asyncua.ua.ua_binary import struct_from_binary

from feeder_cell.gateway.users import Users

__all__ = ["Attempt", "ATTEMPT", "LoginGuard", "install", "thumbprint"]


@dataclass(frozen=True)
class Attempt:
    """An ActivateSession as the gateway saw it before asyncua: who, from where, and its checked answer."""

    address: str
    certificate: str  # SHA-1 thumbprint of the client certificate, "" on a None channel
    user: str | None = None
    password: str | None = None
    checked: bool = False  # the password was checked ahead, off the loop (or refused there, locked out)
    ok: bool | None = None  # the check's answer; None when checked: locked out, not checked at all


# The ActivateSession being processed (set around asyncua's processing of it, in the same task).
ATTEMPT: contextvars.ContextVar[Attempt | None] = contextvars.ContextVar("opcua_login", default=None)


def thumbprint(certificate: bytes | None) -> str:
    """Return a DER certificate's SHA-1 thumbprint as OPC UA clients show it (hex, colons), or ""."""
    if not certificate:
        return ""
    digest = hashlib.sha1(certificate).hexdigest().upper()  # noqa: S324 - a thumbprint, not a signature
    return ":".join(digest[i : i + 2] for i in range(0, len(digest), 2))


@dataclass
class _Tally:
    failures: int = 0
    locked_until: float = 0.0


@dataclass
class LoginGuard:
    """Checks passwords off the loop, keeps the lockouts and counts, and logs every login."""

    users: Users | None
    failures: int = 5  # consecutive failures before each further one locks out
    lockout: float = 30.0  # s an address or a user name is locked out after a failure past ``failures``
    secure_only: bool = False  # no None endpoint: a session on a channel without a certificate is refused
    log: logging.Logger = field(default_factory=lambda: logging.getLogger("opcua_gateway"))
    clock: Callable[[], float] = time.monotonic
    counts: dict[str, int] = field(
        default_factory=lambda: {"logins_accepted": 0, "logins_refused": 0, "logins_locked_out": 0}
    )
    logged: int = 0  # login lines so far (tells the wrapper whether asyncua's refusal was logged)
    _tallies: dict[str, _Tally] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _worker: concurrent.futures.ThreadPoolExecutor = field(
        default_factory=lambda: concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="opcua_login")
    )

    def _keys(self, attempt: Attempt) -> list[str]:
        return [f"address {attempt.address}", f"user {attempt.user}"]

    def locked_for(self, attempt: Attempt) -> float:
        """Return how long the attempt's address or user name is still locked out (0: not)."""
        now = self.clock()
        with self._lock:
            until = max(
                (self._tallies.get(k, _Tally()).locked_until for k in self._keys(attempt)), default=0.0
            )
        return max(0.0, until - now)

    async def check(self, attempt: Attempt) -> bool | None:
        """Check a user-name login's password in the worker thread (the loop goes on); None: locked out."""
        if self.locked_for(attempt) > 0:
            return None
        return await asyncio.get_running_loop().run_in_executor(self._worker, self._verify, attempt)

    def check_now(self, attempt: Attempt) -> bool | None:
        """Check a password here and now (an activation ``install`` did not see); None: locked out."""
        return None if self.locked_for(attempt) > 0 else self._verify(attempt)

    def _verify(self, attempt: Attempt) -> bool:
        return self.users is not None and self.users.check(attempt.user, attempt.password)

    def refuse(self, attempt: Attempt, why: str) -> None:
        """Record and log a login refused before any password check (no certificate, anonymous)."""
        with self._lock:
            self.counts["logins_refused"] += 1
        self.log_login(attempt, f"refused: {why}", warning=True)

    def accept_anonymous(self, attempt: Attempt) -> None:
        """Record and log an anonymous session let in."""
        with self._lock:
            self.counts["logins_accepted"] += 1
        self.log_login(attempt, "accepted", warning=False)

    def decide(self, attempt: Attempt, ok: bool | None) -> bool:
        """Record a password login's outcome (None: refused unchecked, locked out), log it; return ok."""
        now = self.clock()
        with self._lock:
            tallies = [self._tallies.setdefault(k, _Tally()) for k in self._keys(attempt)]
            if ok:
                for tally in tallies:
                    tally.failures, tally.locked_until = 0, 0.0
                outcome, count = "accepted", "logins_accepted"
            elif ok is None:
                left = max(t.locked_until for t in tallies) - now
                outcome, count = f"refused: locked out for {left:.1f} s more", "logins_locked_out"
            else:
                for tally in tallies:
                    tally.failures += 1
                    if tally.failures > self.failures:
                        tally.locked_until = now + self.lockout
                locked = [
                    k for k, t in zip(self._keys(attempt), tallies, strict=True) if t.locked_until > now
                ]
                outcome = "refused: wrong user name or password"
                if locked:
                    outcome += f"; {' and '.join(locked)} locked out for {self.lockout:g} s"
                count = "logins_refused"
            self.counts[count] += 1
        self.log_login(attempt, outcome, warning=not ok)
        return bool(ok)

    def log_login(self, attempt: Attempt, outcome: str, warning: bool) -> None:
        """Log one login line: address, user, certificate thumbprint, outcome (never the password)."""
        with self._lock:
            self.logged += 1
        level = logging.WARNING if warning else logging.INFO
        certificate = attempt.certificate or "none"
        user = attempt.user if attempt.user is not None else "(anonymous)"
        self.log.log(
            level, "login from %s as %s (certificate %s): %s", attempt.address, user, certificate, outcome
        )

    def close(self) -> None:
        """Stop the worker thread (pending checks are dropped)."""
        self._worker.shutdown(wait=False, cancel_futures=True)


_GUARDS: dict[int, LoginGuard] = {}  # id(InternalServer) -> its guard: only the gateway's servers
_ORIGINAL: list[Any] = []


def install(iserver: Any, guard: LoginGuard) -> None:
    """Check the user-name logins of ``iserver``'s sessions with ``guard``, ahead of asyncua's activation.

    asyncua has no hook before ActivateSession's user check, and runs that check on the loop; this wraps
    ``UaProcessor._process_message`` (once per process) for the servers given here, and leaves any other
    asyncua server in the process as it is.
    """
    _GUARDS[id(iserver)] = guard
    if _ORIGINAL:
        return
    original = UaProcessor._process_message
    _ORIGINAL.append(original)
    activate = ua.NodeId(cast(ua.Int32, ua.ObjectIds.ActivateSessionRequest_Encoding_DefaultBinary))

    async def process(self: UaProcessor, typeid: ua.NodeId, requesthdr: Any, seqhdr: Any, body: Any) -> Any:
        guard = _GUARDS.get(id(self.iserver))
        if guard is None or typeid != activate:
            return await original(self, typeid, requesthdr, seqhdr, body)
        attempt = await _attempt(self, guard, body)
        token, said = ATTEMPT.set(attempt), guard.logged
        try:
            return await original(self, typeid, requesthdr, seqhdr, body)
        except Exception as error:
            # Refused before the user manager (a token type not offered): no line yet. asyncua's activation
            # does not yield to the loop, so no other login's line came in between.
            if guard.logged == said:
                code = getattr(error, "code", None)
                name = (
                    ua.StatusCode(cast(ua.UInt32, code)).name
                    if isinstance(code, int)
                    else type(error).__name__
                )
                guard.refuse(attempt, name)
            raise
        finally:
            ATTEMPT.reset(token)

    UaProcessor._process_message = process  # type: ignore[method-assign]


async def _attempt(processor: UaProcessor, guard: LoginGuard, body: Any) -> Attempt:
    """Read an ActivateSession's identity and check a user name's password off the loop."""
    peer = processor.name
    address = str(peer[0]) if isinstance(peer, tuple) and peer else str(peer)
    connection: SecureConnection = processor._connection
    certificate = thumbprint(connection.security_policy.peer_certificate)
    attempt = Attempt(address, certificate)
    try:
        params = struct_from_binary(ua.ActivateSessionParameters, body.copy())  # asyncua reads it again
        token = params.UserIdentityToken
        if not isinstance(token, ua.UserNameIdentityToken) or processor.session is None:
            return attempt
        user, password = processor.iserver.decrypt_user_token(processor.session, token)
    except Exception:  # noqa: BLE001 - asyncua's own processing answers a bad request
        return attempt
    attempt = Attempt(address, certificate, user, password)
    if guard.secure_only and not certificate:
        return attempt  # refused whatever the password (GatewayUsers): no check to spend
    return Attempt(address, certificate, user, password, True, await guard.check(attempt))
