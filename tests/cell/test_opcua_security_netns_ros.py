"""The OPC UA gateway off loopback is secure by default: node-opcua from another host, and refused starts.

The test makes two network namespaces joined by a veth pair (tests/netns.py, as root; only addresses
inside them) and removes them at teardown. On host A the gateway listens on A's veth address with
Basic256Sha256_SignAndEncrypt only, a users file and no certificate given, so it makes its own in a
pki_dir of the test's. From host B node-opcua's client (tests/js, pinned, installed by make setup)
lists the endpoints and logs in over SignAndEncrypt with a user and password; a raw asyncua probe
sends what node-opcua refuses to send. One gateway start serves every case; beside it, starts with
plain defaults and with too little security fail naming the parameter, and the explicit opt-outs log
their warnings. No device runs: the gateway's device variables read Online false.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import netns
import pytest

from feeder_cell.gateway import layout
from feeder_cell.gateway.certificates import CERTIFICATE_NAME, KEY_NAME, thumbprints
from feeder_cell.gateway.users import hash_password
from feeder_cell.launcher import resolve_executable

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
JS = ROOT / "tests" / "js"
CLIENT = JS / "opcua_secure_client.js"
PROBE = Path(__file__).resolve().parent / "scripts" / "opcua_raw_probe.py"
DEVICE, KEY = "/cell/throwing_arm", "cell.throwing_arm"
USER, PASSWORD = "plc", "line-7"  # an Operator
VIEWER = "viewer"  # an Observer, with the same password
LOCKOUT_FAILURES, LOCKOUT_S = 3, 2.0  # the secure gateway's login_failures and login_lockout
SECURE = "Basic256Sha256_SignAndEncrypt"
SERVING = "OPC UA server on"
TIMEOUT_S = 60.0  # generous: four gateways start at once on a loaded two-core machine


def require_node_opcua() -> None:
    """Fail, naming the cause, unless Node.js and the pinned node-opcua-client are installed in tests/js."""
    pinned = json.loads((JS / "package.json").read_text())["dependencies"]["node-opcua-client"]
    if shutil.which("node") is None:
        raise AssertionError("Node.js (node) is not on PATH: node-opcua's client runs on it")
    installed = JS / "node_modules" / "node-opcua-client" / "package.json"
    if installed.is_file() and json.loads(installed.read_text())["version"] == pinned:
        return
    log = JS / "npm-ci.log"
    said = (log.read_text().strip().splitlines() or ["(nothing)"])[-1] if log.is_file() else "(no npm-ci.log)"
    raise AssertionError(
        f"node-opcua-client {pinned} is not installed in tests/js (make setup installs it with npm ci); "
        f"npm ci said: {said}"
    )


CLIENT_URI = "urn:feeder:test:plc"
# name -> (the URI in the certificate, its validity from/to in days from now, the refusal expected)
CERTIFICATES = {
    "valid": (CLIENT_URI, (-1, 365), None),
    "expired": (CLIENT_URI, (-30, -1), "BadCertificateTimeInvalid"),
    "not_yet_valid": (CLIENT_URI, (1, 365), "BadCertificateTimeInvalid"),
    "foreign_uri": ("urn:feeder:test:someone-else", (-1, 365), "BadCertificateUriInvalid"),
}


# An asyncua client that presents a certificate of another application's URI while claiming CLIENT_URI
# (argv: url, certificate, key, user, password); prints one JSON line.
FOREIGN_URI_CLIENT = f"""
import asyncio, json, sys
from asyncua import Client

async def main():
    url, cert, key, user, password = sys.argv[1:6]
    client = Client(url, timeout=10)
    client.application_uri = "{CLIENT_URI}"
    client.set_user(user)
    client.set_password(password)
    await client.set_security_string(f"Basic256Sha256,SignAndEncrypt,{{cert}},{{key}}")
    try:
        await client.connect()
    except Exception as error:
        return {{"ok": False, "error": f"{{type(error).__name__}}: {{error}}".splitlines()[0]}}
    await client.disconnect()
    return {{"ok": True}}

print(json.dumps(asyncio.run(main())))
"""


def client_certificates(folder: Path) -> dict[str, dict[str, str]]:
    """Make each of CERTIFICATES (PEM, for node-opcua); each claims CLIENT_URI as its ApplicationUri."""
    import datetime as dt

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import rsa
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    made = {}
    now = dt.datetime.now(dt.timezone.utc)
    for name, (uri, (start, end), _) in CERTIFICATES.items():
        key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
        certificate = (
            x509.CertificateBuilder()
            .subject_name(subject)
            .issuer_name(subject)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now + dt.timedelta(days=start))
            .not_valid_after(now + dt.timedelta(days=end))
            .add_extension(x509.SubjectAlternativeName([x509.UniformResourceIdentifier(uri)]), critical=False)
            .add_extension(
                x509.KeyUsage(True, True, True, True, False, True, False, False, False), critical=False
            )
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
            .sign(key, hashes.SHA256())
        )
        cert, private = folder / f"{name}_cert.pem", folder / f"{name}_key.pem"
        cert.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
        private.write_bytes(
            key.private_bytes(
                serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
            )
        )
        made[name] = {"cert": str(cert), "key": str(private), "uri": CLIENT_URI}
    return made


@dataclass
class Gateway:
    """A gateway process on a host; its output goes to a log file."""

    process: subprocess.Popen[bytes]
    log: Path

    def output(self) -> str:
        return self.log.read_text(errors="replace") if self.log.exists() else ""

    def stop(self) -> int | None:
        """End it by pid: SIGINT (a clean shutdown), then SIGKILL."""
        if self.process.poll() is None:
            os.kill(self.process.pid, signal.SIGINT)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.kill(self.process.pid, signal.SIGKILL)
                self.process.wait(timeout=10)
        return self.process.returncode


def start_gateway(host: netns.Host, parameters: dict[str, str], env: dict[str, str], log: Path) -> Gateway:
    command = [str(resolve_executable("feeder_cell", "opcua_gateway")), "--ros-args"]
    for name, value in parameters.items():
        command += ["-p", f"{name}:={value}"]
    with open(log, "w") as out:
        process = subprocess.Popen(host.command(command), env=env, stdout=out, stderr=subprocess.STDOUT)
    return Gateway(process, log)


def wait_for(gateway: Gateway, words: str) -> str:
    """Wait until the gateway's log says ``words``; fail with the log if it ends or never says them."""
    deadline = time.monotonic() + TIMEOUT_S
    while words not in gateway.output():
        if gateway.process.poll() is not None or time.monotonic() > deadline:
            raise AssertionError(f"the gateway never logged {words!r}:\n{gateway.output()[-3000:]}")
        time.sleep(0.1)
    return gateway.output()


@dataclass
class Run:
    """Everything the module's one run saw, judged by the tests below."""

    url: str
    pki_dir: Path
    gateway_log: str
    client: dict[str, Any]
    probe: dict[str, Any]
    refused: dict[str, tuple[int | None, str]]  # case -> (exit code, log)
    opted_out_log: str
    client_address: str  # host B's, where node-opcua runs
    foreign_uri: dict[str, Any]  # FOREIGN_URI_CLIENT's session attempt


@pytest.fixture(scope="module")
def run(ros_domain: int, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Run]:
    reason = netns.can_make_namespaces()
    if reason:
        pytest.fail(f"cannot run the OPC UA security test: {reason}")
    require_node_opcua()
    folder = tmp_path_factory.mktemp("opcua_security")
    users = folder / "users.yaml"
    # Fewer PBKDF2 rounds than a real file's: every login costs one check, on a shared test machine.
    users.write_text(
        "users:\n"
        + "".join(
            f'  {name}: {{role: {role}, hash: "{hash_password(PASSWORD, iterations=20_000)}"}}\n'
            for name, role in ((USER, "Operator"), (VIEWER, "Observer"))
        )
    )
    hosts = netns.make_two_hosts(f"ua{os.getpid()}")
    gateways: list[Gateway] = []
    try:
        env = hosts.environment(ros_domain)
        server = hosts.a
        url = f"opc.tcp://{server.address}:4840"  # a namespace of its own: the standard port is free
        pki_dir = folder / "pki"
        secure = start_gateway(
            server,
            {
                "endpoint": url,
                "devices": f"[{DEVICE}]",
                "security_policies": f"[{SECURE}]",
                "allow_anonymous": "false",
                "users_file": str(users),
                "pki_dir": str(pki_dir),
                "login_failures": str(LOCKOUT_FAILURES),
                "login_lockout": str(LOCKOUT_S),
            },
            env,
            folder / "secure.log",
        )
        gateways.append(secure)
        refused_cases = {
            "defaults": {"endpoint": f"opc.tcp://{server.address}:4841"},
            "none_with_users": {
                "endpoint": f"opc.tcp://{server.address}:4842",
                "allow_anonymous": "false",
                "users_file": str(users),
            },
        }
        refused = {
            case: start_gateway(server, parameters, env, folder / f"{case}.log")
            for case, parameters in refused_cases.items()
        }
        gateways += refused.values()
        opted_out = start_gateway(
            server,
            {
                "endpoint": f"opc.tcp://{server.address}:4843",
                "allow_anonymous_remote": "true",
                "allow_insecure_remote": "true",
            },
            env,
            folder / "opted_out.log",
        )
        gateways.append(opted_out)
        gateway_log = wait_for(secure, SERVING)
        opted_out_log = wait_for(opted_out, SERVING)
        opted_out.stop()
        certificates = client_certificates(folder)
        foreign = certificates["foreign_uri"]
        foreign_run = subprocess.run(
            hosts.b.command(
                [
                    sys.executable,
                    "-c",
                    FOREIGN_URI_CLIENT,
                    url,
                    foreign["cert"],
                    foreign["key"],
                    USER,
                    PASSWORD,
                ]
            ),
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        assert foreign_run.returncode == 0, foreign_run.stdout[-3000:] + foreign_run.stderr[-3000:]
        client_run = subprocess.run(
            hosts.b.command(
                [
                    "node",
                    str(CLIENT),
                    json.dumps(
                        {
                            "url": url,
                            "user": USER,
                            "password": PASSWORD,
                            "pki": str(folder / "client_pki"),
                            "key": KEY,
                            "viewer": VIEWER,
                            "certificates": {k: v for k, v in certificates.items() if k != "foreign_uri"},
                            "lockout_failures": LOCKOUT_FAILURES,
                            "lockout_s": LOCKOUT_S,
                        }
                    ),
                ]
            ),
            cwd=JS,
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        assert client_run.returncode == 0, client_run.stdout[-3000:] + client_run.stderr[-3000:]
        probe_run = subprocess.run(
            hosts.b.command([sys.executable, str(PROBE), url, USER, PASSWORD, str(folder / "probe_pki")]),
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        assert probe_run.returncode == 0, probe_run.stdout[-3000:] + probe_run.stderr[-3000:]
        codes = {}
        for case, gateway in refused.items():
            try:
                gateway.process.wait(timeout=TIMEOUT_S)
            finally:
                codes[case] = (gateway.stop(), gateway.output())
        yield Run(
            url,
            pki_dir,
            gateway_log + secure.output()[len(gateway_log) :],
            json.loads(client_run.stdout.strip().splitlines()[-1]),
            json.loads(probe_run.stdout.strip().splitlines()[-1]),
            codes,
            opted_out_log,
            hosts.b.address,
            json.loads(foreign_run.stdout.strip().splitlines()[-1]),
        )
    finally:
        for gateway in gateways:
            gateway.stop()
        hosts.close()
        listed = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
        assert hosts.a.namespace not in listed and hosts.b.namespace not in listed


def test_node_opcua_logs_in_over_sign_and_encrypt_from_another_host_and_reads(run: Run) -> None:
    result = run.client["secure_user"]
    assert result["ok"], run.client
    assert result["product_name"] == "feeder opcua_gateway"
    assert result["online_status"] == "Good" and result["online"] is False  # no device runs


def test_get_endpoints_lists_sign_and_encrypt_with_user_names_only(run: Run) -> None:
    endpoints = run.client["endpoints"]
    assert [(e["mode"], e["policy"], e["tokens"]) for e in endpoints] == [
        ("SignAndEncrypt", "Basic256Sha256", ["UserName"])
    ], endpoints


def test_anonymous_sessions_are_refused(run: Run) -> None:
    # node-opcua will not send a token no endpoint lists; the probe sends it, and the server refuses it.
    assert not run.client["secure_anonymous"]["ok"], run.client
    assert "BadIdentityTokenRejected" in run.probe["secure_anonymous"]["error"], run.probe
    assert "BadIdentityTokenRejected" in run.probe["none_anonymous"]["error"], run.probe


def test_a_none_channel_gets_no_session_even_with_the_right_password(run: Run) -> None:
    assert not any(e["mode"] == "None" or e["policy"] == "None" for e in run.client["endpoints"])
    assert not run.client["none_user"]["ok"], run.client
    # asyncua opens a None channel whatever the policies (for GetEndpoints); the gateway refuses any
    # session on it.
    refusal = run.probe["none_user"]
    assert refusal["stage"] == "activate_session" and "BadUserAccessDenied" in refusal["error"], run.probe


def test_a_wrong_password_is_refused(run: Run) -> None:
    result = run.client["secure_wrong_password"]
    assert not result["ok"] and "BadUserAccessDenied" in result["error"], run.client


def test_the_certificate_made_on_first_start_is_served_and_logged(run: Run) -> None:
    from cryptography import x509

    der = (run.pki_dir / CERTIFICATE_NAME).read_bytes()
    assert (run.pki_dir / KEY_NAME).stat().st_mode & 0o077 == 0  # the key is the gateway user's alone
    sha1, sha256 = thumbprints(der)
    assert f"made a self-signed server certificate {run.pki_dir / CERTIFICATE_NAME}" in run.gateway_log
    assert f"SHA-1 {sha1}, SHA-256 {sha256}" in run.gateway_log
    served = {e["server_certificate_sha256"] for e in run.client["endpoints"]}
    assert served == {sha256.replace(":", "").lower()}
    certificate = x509.load_der_x509_certificate(der)
    names = certificate.extensions.get_extension_for_class(x509.SubjectAlternativeName)
    assert names.value.get_values_for_type(x509.UniformResourceIdentifier) == [layout.APPLICATION_URI]
    assert netns.SUBNET_PREFIX + ".1" in [str(a) for a in names.value.get_values_for_type(x509.IPAddress)]
    assert "Traceback" not in run.gateway_log


def test_off_loopback_starts_without_security_fail_naming_the_parameter(run: Run) -> None:
    for case, words in (
        ("defaults", "parameter allow_anonymous: anonymous clients are allowed on a loopback endpoint only"),
        ("none_with_users", "parameter security_policies: offers None"),
    ):
        code, log = run.refused[case]
        fatal = [line for line in log.splitlines() if "FATAL" in line]
        assert code == 2 and len(fatal) == 1 and words in fatal[0], (case, log)
        assert "Traceback" not in log, log


def test_the_explicit_opt_outs_are_logged_as_warnings(run: Run) -> None:
    warnings = [line for line in run.opted_out_log.splitlines() if "WARN" in line]
    assert any("parameter allow_anonymous_remote: anonymous clients may open sessions" in w for w in warnings)
    assert any("parameter allow_insecure_remote:" in w and "offers None" in w for w in warnings), warnings


def test_a_viewer_may_watch_but_not_command_and_reads_its_own_rights(run: Run) -> None:
    operate = 4096  # PermissionType Call
    viewer, plc = run.client["viewer_rights"], run.client["user_rights"]
    assert viewer["ok"] and plc["ok"], run.client
    assert viewer["stop"] == "BadUserAccessDenied", viewer
    assert "viewer is Observer" in viewer["stop_message"], viewer
    assert "Stop refused: user viewer is Observer" in run.gateway_log
    # The Operator gets past the role: the device (not running here) is what refuses it.
    assert plc["stop"] == "BadInvalidState", plc
    assert viewer["user_executable"] is False and plc["user_executable"] is True
    assert [p["permissions"] & operate for p in viewer["user_role_permissions"]] == [0], viewer
    assert [p["permissions"] & operate for p in plc["user_role_permissions"]] == [operate], plc
    roles = {p["role"]: bool(p["permissions"] & operate) for p in viewer["role_permissions"]}
    # OPC 10000-18's well-known roles: Observer i=15668, Operator i=15680, Engineer i=16036.
    assert roles == {"ns=0;i=15668": False, "ns=0;i=15680": True, "ns=0;i=16036": True}, roles


def test_every_login_is_one_line_with_address_user_certificate_and_outcome(run: Run) -> None:
    assert not run.client["unknown_user"]["ok"], run.client
    assert "BadUserAccessDenied" in run.client["unknown_user"]["error"], run.client
    logins = [line for line in run.gateway_log.splitlines() if "login from " in line]
    prefix = f"login from {run.client_address} as "
    thumbprint = r"[0-9A-F]{2}(:[0-9A-F]{2}){19}"
    for user, outcome in (
        (USER, "accepted"),
        (USER, "refused: wrong user name or password"),
        ("nobody", "refused: wrong user name or password"),
        (VIEWER, "accepted"),
    ):
        pattern = re.escape(f"{prefix}{user} (certificate ") + thumbprint + re.escape(f"): {outcome}")
        assert any(re.search(pattern, line) for line in logins), (user, outcome, logins)
    assert any(f"{prefix}(anonymous)" in line and "refused" in line for line in logins), logins
    assert not any(PASSWORD in line for line in run.gateway_log.splitlines())


def test_failed_logins_lock_the_address_out_and_the_right_password_works_after(run: Run) -> None:
    lockout = run.client["lockout"]
    assert lockout["wrong"] == [False] * (LOCKOUT_FAILURES + 1), lockout
    assert not lockout["right_while_locked"]["ok"], lockout
    assert lockout["right_after"]["ok"], lockout
    assert f"address {run.client_address}" in run.gateway_log and "locked out for 2 s" in run.gateway_log
    assert "refused: locked out for" in run.gateway_log


def test_without_a_trust_list_each_client_certificate_is_checked_for_itself(run: Run) -> None:
    # node-opcua claims its certificate's own URI whatever it is told, so asyncua (FOREIGN_URI_CLIENT)
    # sends the mismatch; node-opcua sends the others.
    results = {**run.client["certificates"], "foreign_uri": run.foreign_uri}
    for name, (_, _, refusal) in CERTIFICATES.items():
        result = results[name]
        if refusal is None:
            assert result["ok"], (name, result)
        else:
            assert not result["ok"] and refusal in result.get("error", ""), (name, result)
