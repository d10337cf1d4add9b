"""The gateway's configuration, checked before anything starts: devices, endpoint, security, PackML states.

Needs no node: the node reads its parameters and hands them here; every error names the parameter (and the
entry) so that a bad start-up is one FATAL line, never a traceback or a silently weaker server.
"""

from __future__ import annotations

import ipaddress
import os
import re
from dataclasses import dataclass
from urllib.parse import urlparse

from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.roles import Role
from feeder_planner.errors import InputError

__all__ = [
    "POLICIES",
    "PACKML",
    "PACKML_STATES",
    "PACKML_UNDEFINED",
    "PACKML_UNCONFIGURED",
    "is_warning",
    "DeviceEntry",
    "Endpoint",
    "SecurityConfig",
    "parse_device_entry",
    "parse_devices",
    "parse_endpoint",
    "is_loopback",
    "check_security",
    "security_warnings",
    "packml_state",
]

# Security policies a client may use, as the parameter security_policies names them.
POLICIES = ("None", "Basic256Sha256_Sign", "Basic256Sha256_SignAndEncrypt")
# The policy a non-loopback endpoint must offer (and the only kind it may offer, Sign beside it aside):
# without encryption anyone on the cell network reads every value, and with None also commands the cell.
SECURE_POLICY = "Basic256Sha256_SignAndEncrypt"

# The PackML states the gateway's PackMLStateEnumeration DataType lists: (number, name, meaning). The
# numbers are ISA-TR88.00.02's PackTags StateCurrent (0 Undefined, 1..17), which are also the StateNumber of
# each state of OPC 30050's PackML state machine types (not OPC 30060's StateEnumeration, 0 Stopped ...
# 16 Unholding). Unconfigured (100) is the gateway's own, outside TR88's range: a device whose ROS
# lifecycle is unconfigured is neither Stopped (Reset does not bring it to Idle) nor unknown.
PACKML_STATES: tuple[tuple[int, str, str], ...] = (
    (0, "Undefined", "no current status from the device (never heard, or its 1 Hz heartbeat missed)"),
    (1, "Clearing", "clearing a fault, on the way from Aborted to Stopped"),
    (2, "Stopped", "stationary, not producing; Reset brings it to Idle"),
    (3, "Starting", "on the way from Idle to Execute"),
    (4, "Idle", "ready: a command starts it"),
    (5, "Suspended", "held by a condition outside the device (the cell paused it)"),
    (6, "Execute", "executing a command or moving"),
    (7, "Stopping", "on the way to Stopped"),
    (8, "Aborting", "on the way to Aborted"),
    (9, "Aborted", "stopped by a fault; Reset clears it once its cause is gone"),
    (10, "Holding", "on the way to Held"),
    (11, "Held", "held by an operator or an internal condition"),
    (12, "Unholding", "on the way from Held back to Execute"),
    (13, "Suspending", "on the way to Suspended"),
    (14, "Unsuspending", "on the way from Suspended back to Execute"),
    (15, "Resetting", "on the way from Stopped or Complete to Idle"),
    (16, "Completing", "finishing a command"),
    (17, "Complete", "a command finished; Reset brings it to Idle"),
    (
        100,
        "Unconfigured",
        "not PackML: the device's lifecycle is unconfigured; it must be configured and activated",
    ),
)
PACKML_UNCONFIGURED = ("Unconfigured", 100)

# feeder_msgs/DeviceStatus state -> (PackML state name, number in PACKML_STATES).
# UNCONFIGURED is Unconfigured: not producing and not commandable, and unlike a device STOPPED, Reset does
# not bring it to Idle (it needs the lifecycle configure and activate). PAUSED (lifecycle inactive, the
# physics frozen by the cell controller) is Suspended: held by a condition outside the device.
PACKML: dict[int, tuple[str, int]] = {
    0: PACKML_UNCONFIGURED,  # UNCONFIGURED
    1: ("Idle", 4),  # IDLE
    2: ("Execute", 6),  # RUNNING
    3: ("Suspended", 5),  # PAUSED
    4: ("Aborted", 9),  # FAULT
    5: ("Stopped", 2),  # STOPPED
}
# No current status from the device (never heard, or its 1 Hz heartbeat missed): PackTags' Undefined.
PACKML_UNDEFINED = ("Undefined", 0)

_NAME = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")


@dataclass(frozen=True)
class DeviceEntry:
    """One device the gateway exposes: its kind and fully qualified node name."""

    kind: str
    node: str  # e.g. /cell/throwing_arm

    @property
    def key(self) -> str:
        """The device's name in the address space (NodeId prefix): the node name, dots for slashes."""
        return self.node.strip("/").replace("/", ".")


def parse_device_entry(entry: str, index: int) -> DeviceEntry:
    """Parse ``[KIND:]NODE``; without KIND the node's own name (its executable's) must be a kind."""
    field = f"parameter devices[{index}]"
    text = entry.strip()
    kind, sep, node = text.rpartition(":")
    if not sep:
        kind, node = "", text
    if not _NAME.match(node):
        raise InputError(
            field, f"must be a fully qualified node name such as /cell/throwing_arm, got {entry!r}"
        )
    if not kind:
        kind = node.rsplit("/", 1)[1]
        if kind not in KINDS:
            raise InputError(
                field,
                f"node name {kind!r} is not a device kind ({', '.join(KINDS)}); "
                f"give the kind explicitly as KIND:{node}",
            )
    elif kind not in KINDS:
        raise InputError(field, f"unknown device kind {kind!r} (expected one of {', '.join(KINDS)})")
    return DeviceEntry(kind, node)


def parse_devices(entries: list[str]) -> tuple[DeviceEntry, ...]:
    """Parse the devices parameter (empty strings are skipped); a device listed twice is refused."""
    devices: list[DeviceEntry] = []
    for index, entry in enumerate(entries):
        if not entry.strip():
            continue
        device = parse_device_entry(entry, index)
        if any(d.key == device.key for d in devices):
            raise InputError(f"parameter devices[{index}]", f"{device.node} is listed twice")
        devices.append(device)
    return tuple(devices)


@dataclass(frozen=True)
class Endpoint:
    """The OPC UA endpoint the server listens on."""

    url: str
    host: str
    port: int


def parse_endpoint(url: str) -> Endpoint:
    """Parse ``opc.tcp://HOST:PORT[/path]``; errors name the parameter endpoint."""
    field = "parameter endpoint"
    parsed = urlparse(url.strip())
    if parsed.scheme != "opc.tcp":
        raise InputError(field, f"must be an opc.tcp://HOST:PORT URL, got {url!r}")
    try:
        port = parsed.port
    except ValueError:
        raise InputError(field, f"has a bad port in {url!r}") from None
    if not parsed.hostname or port is None or not 0 < port < 65536:
        raise InputError(field, f"needs a host and a port in 1..65535, got {url!r}")
    return Endpoint(url.strip(), parsed.hostname, port)


def is_loopback(host: str) -> bool:
    """Whether the host is a loopback address (``localhost`` counts; any other name does not)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name that might resolve anywhere: not provably loopback


@dataclass(frozen=True)
class SecurityConfig:
    """Checked security settings: policies, the server's certificate and key, and who may log in.

    Empty certificate and key files with a Basic256Sha256 policy mean the node makes (or reuses) a
    self-signed certificate in ``pki_dir`` before the server starts (``certificates.ensure_certificate``).
    """

    policies: tuple[str, ...]
    certificate_file: str
    private_key_file: str
    allow_anonymous: bool
    users_file: str
    trusted_certificates_dir: str = ""  # empty: any issuer (still checked for itself)
    pki_dir: str = ""  # empty: certificates.default_pki_dir()
    remote: bool = False  # the endpoint is not a loopback address
    insecure_remote: bool = False  # remote, offering None or no encryption, by allow_insecure_remote
    anonymous_role: Role = Role.Engineer  # an anonymous session's rights (roles.Role)
    login_failures: int = 5  # consecutive failed logins (an address's, a user's) before lockouts (logins)
    login_lockout: float = 30.0  # s each failure past login_failures locks the address or user out

    @property
    def makes_certificate(self) -> bool:
        """Whether the server's certificate is made (or reused) in pki_dir rather than given."""
        return any(p != "None" for p in self.policies) and not self.certificate_file


def _readable(path: str, field: str) -> None:
    if not os.path.isfile(path) or not os.access(path, os.R_OK):
        raise InputError(field, f"cannot read {path!r}")


def check_security(
    endpoint: Endpoint,
    policies: list[str],
    certificate_file: str,
    private_key_file: str,
    allow_anonymous: bool,
    allow_anonymous_remote: bool,
    users_file: str,
    trusted_certificates_dir: str = "",
    allow_insecure_remote: bool = False,
    pki_dir: str = "",
) -> SecurityConfig:
    """Check the security parameters against each other and the endpoint; errors name the parameter.

    On a loopback endpoint anything goes (the default: None, anonymous). On any other endpoint (0.0.0.0
    and host names included: they are not provably loopback) a gateway bound to a factory network must
    not take commands from anyone by default: it must offer Basic256Sha256_SignAndEncrypt and not None,
    and log users in with passwords; anonymous sessions need ``allow_anonymous_remote``, and None or a
    Sign-only server ``allow_insecure_remote``, each explicit and logged as a warning at start.
    """
    # The checks run in this order, and the first that fails is the one error reported.
    chosen = _chosen_policies(policies)
    secure = any(p != "None" for p in chosen)
    if secure:
        _check_certificate_pair(certificate_file, private_key_file)
    _check_pki_dir(pki_dir, secure, certificate_file)
    if users_file:
        _readable(users_file, "parameter users_file")
    _check_trusted_certificates_dir(trusted_certificates_dir, secure)
    _check_someone_can_log_in(allow_anonymous, users_file)
    remote = not is_loopback(endpoint.host)
    _check_remote_anonymous(endpoint, remote, allow_anonymous, allow_anonymous_remote)
    insecure = "None" in chosen or SECURE_POLICY not in chosen
    _check_remote_policies(endpoint, chosen, remote and insecure, allow_insecure_remote)
    return SecurityConfig(
        chosen,
        certificate_file,
        private_key_file,
        allow_anonymous,
        users_file,
        trusted_certificates_dir,
        pki_dir,
        remote,
        remote and insecure,
    )


def _chosen_policies(policies: list[str]) -> tuple[str, ...]:
    """Return the policies named (blank entries skipped): at least one, each known, none twice."""
    chosen = tuple(p.strip() for p in policies if p.strip())
    if not chosen:
        raise InputError("parameter security_policies", f"needs at least one of {', '.join(POLICIES)}")
    for index, policy in enumerate(chosen):
        if policy not in POLICIES:
            raise InputError(
                f"parameter security_policies[{index}]",
                f"unknown policy {policy!r} (expected one of {', '.join(POLICIES)})",
            )
    if len(set(chosen)) != len(chosen):
        raise InputError("parameter security_policies", f"lists a policy twice: {list(chosen)}")
    return chosen


def _check_certificate_pair(certificate_file: str, private_key_file: str) -> None:
    """Check a secure server's certificate and key: both given and readable, or neither (one made)."""
    # Both or neither: one file alone is a half-configured server, never silently completed.
    pair = (("certificate_file", certificate_file), ("private_key_file", private_key_file))
    for (name, path), (other, given) in zip(pair, reversed(pair), strict=True):
        if not path and given:
            raise InputError(
                f"parameter {name}",
                f"is required with {other} (leave both empty to have a self-signed certificate "
                "made in pki_dir)",
            )
    for name, path in pair:
        if path:
            _readable(path, f"parameter {name}")


def _check_pki_dir(pki_dir: str, secure: bool, certificate_file: str) -> None:
    """Refuse a pki_dir that would not be used: no secure policy, or a certificate given."""
    if pki_dir and (not secure or certificate_file):
        raise InputError(
            "parameter pki_dir",
            "is used only when a Basic256Sha256 policy is served without certificate_file and "
            "private_key_file",
        )


def _check_trusted_certificates_dir(trusted_certificates_dir: str, secure: bool) -> None:
    """Check a trust list: only beside a secure policy, and a folder."""
    if not trusted_certificates_dir:
        return
    if not secure:
        raise InputError(
            "parameter trusted_certificates_dir",
            "applies to the Basic256Sha256 policies only, and security_policies has none",
        )
    if not os.path.isdir(trusted_certificates_dir):
        raise InputError(
            "parameter trusted_certificates_dir", f"is not a folder: {trusted_certificates_dir!r}"
        )


def _check_someone_can_log_in(allow_anonymous: bool, users_file: str) -> None:
    """Refuse settings under which no client could open a session."""
    if not allow_anonymous and not users_file:
        raise InputError(
            "parameter allow_anonymous", "is false and no users_file is given: no client could log in"
        )


def _check_remote_anonymous(
    endpoint: Endpoint, remote: bool, allow_anonymous: bool, allow_anonymous_remote: bool
) -> None:
    """Refuse anonymous sessions off loopback unless allow_anonymous_remote says so explicitly."""
    if remote and allow_anonymous and not allow_anonymous_remote:
        raise InputError(
            "parameter allow_anonymous",
            f"anonymous clients are allowed on a loopback endpoint only, and {endpoint.url} is not one; "
            f"set allow_anonymous false with a users_file (and security_policies [{SECURE_POLICY}]), "
            "or allow_anonymous_remote true to allow anonymous access from the network explicitly",
        )


def _check_remote_policies(
    endpoint: Endpoint, chosen: tuple[str, ...], insecure_remote: bool, allow_insecure_remote: bool
) -> None:
    """Refuse None or Sign alone off loopback unless allow_insecure_remote says so explicitly."""
    if insecure_remote and not allow_insecure_remote:
        what = (
            "offers None (no signature, no encryption)"
            if "None" in chosen
            else "offers no encryption (Basic256Sha256_Sign alone)"
        )
        raise InputError(
            "parameter security_policies",
            f"{what} on {endpoint.url}, which is not a loopback endpoint; serve [{SECURE_POLICY}] "
            "(a self-signed certificate is made in pki_dir if none is given), or set "
            "allow_insecure_remote true to allow it explicitly",
        )


def security_warnings(endpoint: Endpoint, security: SecurityConfig) -> list[str]:
    """Return the WARNING lines a start with these settings logs: each explicit weakening, named."""
    warnings: list[str] = []
    if not security.remote:
        return warnings
    if security.allow_anonymous:
        warnings.append(
            f"parameter allow_anonymous_remote: anonymous clients may open sessions on {endpoint.url} "
            "from the network, and read and command the cell"
        )
    if security.insecure_remote:
        weak = [p for p in security.policies if p != SECURE_POLICY]
        warnings.append(
            f"parameter allow_insecure_remote: {endpoint.url} offers {', '.join(weak)} to the network: "
            + (
                "anyone who reaches it can read and command the cell unencrypted"
                if "None" in weak
                else "values cross the network unencrypted"
            )
        )
    if security.users_file and security.policies == ("None",):
        warnings.append(
            "parameter users_file: passwords cross the network in plain text on a non-loopback endpoint "
            f"with security_policies [None]; add {SECURE_POLICY}"
        )
    return warnings


def is_warning(state: int, fault_code: int) -> bool:
    """Whether a DeviceStatus fault code is a warning: reported while the device stays operational.

    A stopping fault puts the device in FAULT, and a failed configuration leaves it UNCONFIGURED with code
    1: those codes are faults (Status/FaultCode). In any other state (IDLE, RUNNING, PAUSED, STOPPED) a
    non-zero code is a non-stopping fault (behind real time, a too stiff time step, an axis rate limit):
    a warning, shown in Status/WarningCode. A STOPPED device that falls behind real time is not faulted.
    """
    return fault_code != 0 and state not in (0, 4)  # UNCONFIGURED, FAULT


def packml_state(state: int | None) -> tuple[str, int]:
    """Return the PackML (name, number) of a DeviceStatus state; None (no current status): Undefined."""
    if state is None:
        return PACKML_UNDEFINED
    return PACKML.get(state, PACKML_UNDEFINED)
