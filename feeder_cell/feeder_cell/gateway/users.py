"""User/password logins of the gateway: a YAML users file with salted PBKDF2-SHA256 hashes and roles.

The file maps user names to their role (``roles.Role``: Observer, Operator or Engineer) and hash, the
line made by ``python -m feeder_cell.gateway.users NAME ROLE`` (it asks for the password)::

    users:
      plc: {role: Operator, hash: "pbkdf2_sha256$200000$<salt, base64>$<hash, base64>"}

Each hash carries its own salt and iteration count; a check compares in constant time. An entry without
a role is refused at start, naming the user: nobody gets rights by omission.
"""

from __future__ import annotations

import base64
import functools
import getpass
import hashlib
import hmac
import os
import sys
from dataclasses import dataclass, field

from feeder_cell.gateway.roles import Role, parse_role
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping

__all__ = ["ITERATIONS", "hash_password", "verify_password", "Users", "load_users", "main"]

ITERATIONS = 200_000  # PBKDF2 rounds of a new hash: about 0.1 s per login check on one core
_SCHEME = "pbkdf2_sha256"


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def hash_password(password: str, iterations: int = ITERATIONS, salt: bytes | None = None) -> str:
    """Return ``pbkdf2_sha256$ITERATIONS$SALT$HASH`` for a password (a fresh 16-byte salt by default)."""
    salt = os.urandom(16) if salt is None else salt
    digest = hashlib.pbkdf2_hmac("sha256", password.encode("utf-8"), salt, iterations)
    return f"{_SCHEME}${iterations}${_b64(salt)}${_b64(digest)}"


def _parse_hash(text: str, field: str) -> tuple[int, bytes, bytes]:
    parts = text.split("$") if isinstance(text, str) else []
    if len(parts) != 4 or parts[0] != _SCHEME:
        raise InputError(
            field, f"must be {_SCHEME}$ITERATIONS$SALT$HASH (python -m feeder_cell.gateway.users)"
        )
    try:
        iterations = int(parts[1])
        salt, digest = base64.b64decode(parts[2], validate=True), base64.b64decode(parts[3], validate=True)
    except ValueError:
        raise InputError(field, "has a bad iteration count or base64 salt/hash") from None
    if iterations < 1 or not salt or len(digest) != hashlib.sha256().digest_size:
        raise InputError(field, "has a bad iteration count, an empty salt or a hash of the wrong length")
    return iterations, salt, digest


def verify_password(password: str, stored: str) -> bool:
    """Return whether ``password`` matches a stored hash (constant-time comparison)."""
    iterations, salt, digest = _parse_hash(stored, "hash")
    candidate = hashlib.pbkdf2_hmac("sha256", password.encode("utf-8"), salt, iterations)
    return hmac.compare_digest(candidate, digest)


@dataclass(frozen=True)
class Users:
    """The users allowed to log in with a password: name -> stored hash, name -> role."""

    hashes: dict[str, str]
    roles: dict[str, Role] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # Made now, not at the first unknown name: that check would otherwise cost two.
        if self.hashes:
            _ = self._dummy

    def role(self, name: str) -> Role:
        """Return a user's role (Observer for a name without one: no rights by omission)."""
        return self.roles.get(name, Role.Observer)

    def check(self, name: str | None, password: str | None) -> bool:
        """Return whether the name is a user and the password is theirs.

        An unknown name is checked against a dummy hash of the users' iteration count, so that it takes
        as long as a known name's wrong password: the time of a refusal does not tell which names exist.
        """
        stored = self.hashes.get(name or "")
        ok = verify_password(password or "", stored if stored is not None else self._dummy)
        return ok and stored is not None and password is not None

    @functools.cached_property
    def _dummy(self) -> str:
        rounds = [_parse_hash(h, "hash")[0] for h in self.hashes.values()] or [ITERATIONS]
        return hash_password(os.urandom(16).hex(), iterations=max(rounds))


def load_users(path: str) -> Users:
    """Read a users file; errors name the file and the user's entry."""
    try:
        document = load_yaml_mapping(path)
        users = document.get("users")
        if not isinstance(users, dict) or not users:
            raise InputError("users", "expected a non-empty mapping of user names to password hashes")
        hashes: dict[str, str] = {}
        roles: dict[str, Role] = {}
        for name, entry in users.items():
            if not isinstance(name, str) or not name:
                raise InputError("users", f"user names must be non-empty strings, got {name!r}")
            where = f"users.{name}"
            if not isinstance(entry, dict) or "role" not in entry:
                raise InputError(
                    where,
                    "has no role: write {role: Observer|Operator|Engineer, hash: ...} "
                    "(python -m feeder_cell.gateway.users NAME ROLE)",
                )
            unknown = sorted(set(entry) - {"role", "hash"})
            if unknown:
                raise InputError(f"{where}.{unknown[0]}", "is not a field of a user (role, hash)")
            roles[name] = parse_role(entry["role"], f"{where}.role")
            _parse_hash(str(entry.get("hash", "")), f"{where}.hash")
            hashes[name] = entry["hash"]
    except InputError as error:
        raise InputError("parameter users_file", str(error.with_source(path))) from None
    return Users(hashes, roles)


def main(argv: list[str] | None = None) -> int:
    """Ask for a password and print the users-file line for the user and role named on the command line."""
    args = sys.argv[1:] if argv is None else argv
    usage = "usage: python -m feeder_cell.gateway.users NAME ROLE  (ROLE: Observer, Operator or Engineer)"
    if len(args) != 2 or not args[0]:
        print(usage, file=sys.stderr)
        return 2
    try:
        role = parse_role(args[1], "ROLE")
    except InputError as error:
        print(f"{error}; {usage}", file=sys.stderr)
        return 2
    password = getpass.getpass(f"password for {args[0]}: ")
    if not password or password != getpass.getpass("again: "):
        print("the passwords are empty or differ", file=sys.stderr)
        return 1
    print(f'  {args[0]}: {{role: {role.name}, hash: "{hash_password(password)}"}}')
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
