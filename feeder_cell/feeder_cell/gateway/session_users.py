"""Who may open a session on the gateway: asyncua's user manager, deciding by the security settings.

Separate from the server's wiring because it is the one answer to "may this client in?", and from the
``LoginGuard`` (``logins``) because the guard counts, logs and locks out while this class only decides
from what the session presents. It runs on the asyncio loop and holds no lock of its own.
"""

from __future__ import annotations

from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.internal_server import InternalServer
from asyncua.server.user_managers import UserManager

from feeder_cell.gateway.logins import ATTEMPT, Attempt, LoginGuard, thumbprint
from feeder_cell.gateway.roles import GatewayUser, Role
from feeder_cell.gateway.users import Users

__all__ = ["GatewayUsers"]


class GatewayUsers(UserManager):
    """Who may open a session: anonymous (when allowed) and the users file's names with their passwords.

    With ``secure_only`` (the server offers no None endpoint) a session on a channel without a client
    certificate is refused whoever asks: asyncua accepts a None channel whatever the policies (for
    GetEndpoints) and would create and activate sessions on it, unsigned and unencrypted. Each answer is
    recorded and logged by the ``LoginGuard``, which has usually checked the password already, off the
    loop (``logins.ATTEMPT``).
    """

    def __init__(
        self,
        users: Users | None,
        allow_anonymous: bool,
        secure_only: bool = False,
        anonymous_role: Role = Role.Engineer,
        guard: LoginGuard | None = None,
    ) -> None:
        self.users = users
        self.allow_anonymous = allow_anonymous
        self.secure_only = secure_only
        self.anonymous_role = anonymous_role
        self.guard = guard or LoginGuard(users, secure_only=secure_only)

    def get_user(
        self,
        iserver: InternalServer,
        username: str | None = None,
        password: str | None = None,
        certificate: object = None,
    ) -> User | None:
        """Return the session's user, or None (BadUserAccessDenied)."""
        seen = ATTEMPT.get()
        address = seen.address if seen is not None else "an unknown address"
        presented = thumbprint(certificate) if isinstance(certificate, bytes) else ""
        attempt = Attempt(address, presented or (seen.certificate if seen is not None else ""), username)
        if self.secure_only and not certificate:
            # A None channel: only a secured one carries the client's certificate.
            self.guard.refuse(attempt, "a channel without a client certificate (security None)")
            return None
        if username is None and password is None:
            if not self.allow_anonymous:
                self.guard.refuse(attempt, "anonymous sessions are not allowed")
                return None
            self.guard.accept_anonymous(attempt)
            return GatewayUser(role=UserRole.User, name="anonymous", access=self.anonymous_role)
        if self.users is None or not username:
            self.guard.refuse(attempt, "no user name, or no users file")
            return None
        ahead = seen is not None and seen.checked and seen.user == username and seen.password == password
        checking = Attempt(attempt.address, attempt.certificate, username, password)
        ok = seen.ok if ahead and seen is not None else self.guard.check_now(checking)
        if not self.guard.decide(attempt, ok):
            return None
        return GatewayUser(role=UserRole.User, name=username, access=self.users.role(username))
