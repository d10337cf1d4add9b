"""`feeder bridge` refuses to start unsafely off loopback, and on bad TLS files: one line naming the option.

Every case here is refused before anything binds or ROS starts, so the non-loopback address 0.0.0.0 is
never served. What the bridge does once it serves off loopback (wss://, the opt-outs' warnings, what a
remote client may do) is tests/bridge/test_bridge_security_netns_ros.py, across two network namespaces.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from bridge_certificates import make_certificate

TIMEOUT = 60.0


def refused(*args: str) -> str:
    """Run `feeder bridge ARGS`; assert it exits 2 with exactly one stderr line; return that line."""
    run = subprocess.run(
        [sys.executable, "-m", "feeder_cell.cli.main", "bridge", "--port", "0", *args],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        env=dict(os.environ),
    )
    lines = run.stderr.splitlines()
    assert run.returncode == 2 and len(lines) == 1, (run.returncode, run.stdout, run.stderr)
    assert run.stdout == "", run.stdout  # it never said it serves
    assert lines[0].startswith("feeder bridge: "), lines
    return lines[0]


@pytest.fixture(scope="module")
def tls(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("bridge_tls")
    cert, key = make_certificate(folder, "good", ("127.0.0.1",))
    other_cert, other_key = make_certificate(folder, "other", ("127.0.0.1",))
    _, encrypted_key = make_certificate(folder, "encrypted", ("127.0.0.1",), encrypt_key=True)
    expired_cert, expired_key = make_certificate(folder, "expired", ("127.0.0.1",), valid_days=(-30, -1))
    future_cert, future_key = make_certificate(folder, "future", ("127.0.0.1",), valid_days=(1, 30))
    garbage = folder / "garbage.pem"
    garbage.write_text("-----BEGIN CERTIFICATE-----\nnot base64 at all\n-----END CERTIFICATE-----\n")
    unreadable = folder / "unreadable.pem"
    unreadable.write_bytes(key.read_bytes())
    unreadable.chmod(0)
    return {
        "cert": cert,
        "key": key,
        "other_key": other_key,
        "encrypted_key": encrypted_key,
        "garbage": garbage,
        "unreadable": unreadable,
        "directory": folder,
        "expired_cert": expired_cert,
        "expired_key": expired_key,
        "future_cert": future_cert,
        "future_key": future_key,
    }


def test_a_non_loopback_address_without_tls_is_refused_naming_the_option() -> None:
    line = refused("--address", "0.0.0.0")
    assert line.startswith("feeder bridge: --tls-cert: 0.0.0.0 is not a loopback address"), line
    assert "--allow-insecure-remote" in line  # the explicit way out is named too
    # --read-only does not make plain ws:// acceptable off loopback: the traffic is still readable.
    assert refused("--address", "0.0.0.0", "--read-only").startswith("feeder bridge: --tls-cert: "), line


@pytest.mark.parametrize("address", ["0.0.0.0", "192.0.2.7", "cell-host.example", "::"])
def test_control_off_loopback_needs_read_only_or_the_opt_in(address: str) -> None:
    line = refused("--address", address, "--allow-insecure-remote")
    assert line.startswith(f"feeder bridge: --allow-remote-control: {address} is not a loopback address"), (
        line
    )
    assert "--read-only" in line


def test_control_is_refused_off_loopback_with_tls_too(tls: dict[str, Path]) -> None:
    line = refused("--address", "0.0.0.0", "--tls-cert", str(tls["cert"]), "--tls-key", str(tls["key"]))
    assert line.startswith("feeder bridge: --allow-remote-control: "), line


def test_bad_tls_files_are_one_line_naming_the_option(tls: dict[str, Path]) -> None:
    cert, key = str(tls["cert"]), str(tls["key"])
    cases = {
        ("--tls-cert", cert): "--tls-key: is required with --tls-cert",
        ("--tls-key", key): "--tls-cert: is required with --tls-key",
        ("--tls-cert", "/no/such.pem", "--tls-key", key): "--tls-cert: cannot read '/no/such.pem'",
        ("--tls-cert", cert, "--tls-key", "/no/such.pem"): "--tls-key: cannot read '/no/such.pem'",
        ("--tls-cert", str(tls["directory"]), "--tls-key", key): "--tls-cert: cannot read",
        ("--tls-cert", str(tls["garbage"]), "--tls-key", key): "--tls-cert: '"
        + str(tls["garbage"])
        + "' is not a PEM certificate",
        ("--tls-cert", key, "--tls-key", key): "is not a PEM certificate",
        ("--tls-cert", cert, "--tls-key", cert): "--tls-key: '" + cert + "' is not a PEM private key",
        ("--tls-cert", cert, "--tls-key", str(tls["other_key"])): "--tls-key: '"
        + str(tls["other_key"])
        + "' does not match the certificate of --tls-cert",
        ("--tls-cert", cert, "--tls-key", str(tls["encrypted_key"])): "is encrypted; give an unencrypted key",
    }
    for when, said in (("expired", "expired on "), ("future", "is valid only from ")):
        cases[("--tls-cert", str(tls[f"{when}_cert"]), "--tls-key", str(tls[f"{when}_key"]))] = (
            "--tls-cert: '" + str(tls[f"{when}_cert"]) + "' " + said
        )
    if os.geteuid() != 0:  # root reads a file whatever its mode
        cases[("--tls-cert", cert, "--tls-key", str(tls["unreadable"]))] = "--tls-key: cannot read"
    for args, said in cases.items():
        # On loopback too: a bad certificate is never served in plain text instead.
        line = refused(*args)
        assert said in line, (args, line)
