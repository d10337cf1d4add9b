"""The Foxglove bridge off loopback, from another host: wss:// only, and control only when allowed.

As the OPC UA gateway's security test does, the module makes two network namespaces joined by a veth
pair (tests/netns.py, as root; only addresses inside them) and removes them at teardown. On host A run
a small ROS node (a parameter, its parameter services, a topic) and three bridges on A's veth address:
TLS and --read-only; TLS and --allow-remote-control; plain ws:// by --allow-insecure-remote and
--read-only; and, on the same address, starts without TLS or with control not allowed are refused.
From host B the official client (@foxglove/ws-protocol on Node.js, tests/js) connects, trusting the
test's self-signed certificate through NODE_EXTRA_CA_CERTS as any Node.js program can.
"""

from __future__ import annotations

import base64
import itertools
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import netns
import pytest
from bridge_certificates import make_certificate
from bridge_process import BridgeProcess
from test_bridge_official_client_ros import SUBPROTOCOLS, OfficialClient, cdr, require_official_client

pytestmark = pytest.mark.ros

NODE, PARAMETER, TOPIC = "/remote/probe", "rate", "/remote/probe/chatter"
DISCOVERY_TIMEOUT = 60.0  # s for a bridge to discover the probe node on the other host (20: short at load 10)
REFUSAL_TIMEOUT = 15.0  # s: a refused connection closes at once; this only bounds a hang

# A node on host A: one double parameter (rate, 2.0) and a String topic at 10 Hz.
PROBE_NODE = f"""
import rclpy
from rclpy.executors import ExternalShutdownException
from std_msgs.msg import String

rclpy.init()
node = rclpy.create_node("probe", namespace="/remote")
node.declare_parameter("{PARAMETER}", 2.0)
publisher = node.create_publisher(String, "{TOPIC}", 10)
node.create_timer(0.1, lambda: publisher.publish(String(data="from host A")))
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
"""


@dataclass
class Hosts:
    """The module's two hosts, the bridges on A, and how B's client runs."""

    hosts: netns.TwoHosts
    env: dict[str, str]
    certificate: Path
    key: Path
    read_only: BridgeProcess
    control: BridgeProcess
    plain: BridgeProcess

    def client(self, url: str, subprotocol: str, trusted: bool = True) -> OfficialClient:
        """The official client on host B; ``trusted``: the bridge's certificate is a CA it trusts."""
        env = dict(self.env)
        if trusted:
            env["NODE_EXTRA_CA_CERTS"] = str(self.certificate)
        return OfficialClient(url, subprotocol, wrap=self.hosts.b.command, env=env)

    def refusal(self, url: str, trusted: bool = True) -> str:
        """Connect from host B expecting a refusal; return what the client said."""
        with pytest.raises(AssertionError) as refused:
            self.client(url, SUBPROTOCOLS[0], trusted).close()
        return str(refused.value)


def wait_until_seen(client: OfficialClient, name: str) -> None:
    """Wait until the bridge has discovered the probe's parameter services across the two hosts.

    Until then the bridge rightly answers that no node takes the request; discovery between the
    namespaces can take a few seconds after the bridge starts, and the module's first tests are faster.
    """
    deadline = time.monotonic() + DISCOVERY_TIMEOUT
    mark = client.mark()
    for attempt in itertools.count():
        # A fresh id each time: the client keeps every parameterValues it got and answers a request with
        # the first one of its id, so a repeated id returned the first, empty answer for ever (the bridge
        # had not yet seen the probe then), and the module failed whenever its first look came too early.
        read = client.request("getParameters", names=[name], requestId=f"seen-{attempt}")["parameters"]
        if read:
            return
        said = sorted(set(client.statuses(mark["statuses"], "")))
        assert time.monotonic() < deadline, f"bridge did not see {name} in {DISCOVERY_TIMEOUT:g} s: {said}"
        time.sleep(0.2)


@pytest.fixture(scope="module")
def remote(ros_domain: int, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Hosts]:
    reason = netns.can_make_namespaces()
    if reason:
        pytest.fail(f"cannot run the bridge security test: {reason}")
    require_official_client()
    folder = tmp_path_factory.mktemp("bridge_security")
    hosts = netns.make_two_hosts(f"fx{os.getpid()}")
    started: list[BridgeProcess] = []
    probe: subprocess.Popen[bytes] | None = None
    try:
        env = hosts.environment(ros_domain)
        a = hosts.a
        cert, key = make_certificate(folder, "bridge", (a.address,))
        with open(folder / "probe.log", "w") as log:
            probe = subprocess.Popen(
                a.command([sys.executable, "-c", PROBE_NODE]), env=env, stdout=log, stderr=subprocess.STDOUT
            )
        tls = ("--address", a.address, "--tls-cert", str(cert), "--tls-key", str(key))
        for args, serving in (
            ((*tls, "--read-only"), "wss://"),
            ((*tls, "--allow-remote-control"), "wss://"),
            (("--address", a.address, "--allow-insecure-remote", "--read-only"), "ws://"),
        ):
            started.append(BridgeProcess(*args, serving=f"{serving}{a.address}:", wrap=a.command, env=env))
        yield Hosts(hosts, env, cert, key, *started)
    finally:
        for bridge in started:
            bridge.stop()
        if probe is not None:
            probe.send_signal(signal.SIGINT)  # rclpy shuts down cleanly
            try:
                probe.wait(timeout=10)
            except subprocess.TimeoutExpired:
                probe.kill()
                probe.wait(timeout=10)
        hosts.close()


@pytest.mark.parametrize("subprotocol", SUBPROTOCOLS)
def test_a_trusting_client_on_another_host_subscribes_over_wss(remote: Hosts, subprotocol: str) -> None:
    from std_msgs.msg import String

    assert remote.read_only.url.startswith("wss://")
    client = remote.client(remote.read_only.url, subprotocol)
    try:
        assert client.protocol == subprotocol
        messages = client.messages(client.subscribe(TOPIC), 2)
        from rclpy.serialization import deserialize_message

        assert deserialize_message(messages[0], String).data == "from host A"
        assert client.request("errors")["errors"] == []
    finally:
        client.close()


def test_a_client_that_does_not_trust_the_certificate_is_refused(remote: Hosts) -> None:
    said = remote.refusal(remote.read_only.url, trusted=False)
    assert "certificate" in said, said  # Node.js: "self-signed certificate"
    assert remote.read_only.process.poll() is None, remote.read_only.output()  # the bridge serves on
    assert "Traceback" not in remote.read_only.output(), remote.read_only.output()


def test_plain_ws_to_the_tls_port_is_refused(remote: Hosts) -> None:
    plain = remote.read_only.url.replace("wss://", "ws://", 1)
    said = remote.refusal(plain)
    assert "connection closed (code 1006" in said, said  # no WebSocket handshake, so no serverInfo
    assert "Traceback" not in remote.read_only.output(), remote.read_only.output()
    # And the bridge still serves wss:// to the next client.
    client = remote.client(remote.read_only.url, SUBPROTOCOLS[0])
    client.close()


def test_without_the_opt_in_services_and_parameter_sets_are_refused(remote: Hosts) -> None:
    from rcl_interfaces.srv import GetParameters

    client = remote.client(remote.read_only.url, SUBPROTOCOLS[0])
    try:
        assert set(client.server_info["capabilities"]) == {
            "parameters",
            "parametersSubscribe",
            "connectionGraph",
        }
        name = f"{NODE}.{PARAMETER}"
        wait_until_seen(client, name)
        mark = client.mark()
        values = client.request("setParameters", parameters=[{"name": name, "value": 7.0}], requestId="r")
        assert values["parameters"] == [{"name": name, "value": 2.0, "type": "float64"}]  # unchanged
        client.statuses(mark["statuses"], "setParameters: refused: the bridge is read-only")
        failure = client.request(
            "callById", serviceId=1, request=cdr(GetParameters.Request(names=[PARAMETER]))
        )
        assert failure["failure"] == "service call: refused: the bridge is read-only (--read-only)"
    finally:
        client.close()
    assert "WARNING" not in remote.read_only.output()  # TLS and read-only: nothing opted out


def test_with_the_opt_in_services_and_parameters_are_answered(remote: Hosts) -> None:
    from rcl_interfaces.srv import GetParameters

    client = remote.client(remote.control.url, SUBPROTOCOLS[0])
    try:
        assert {"services", "parameters", "clientPublish"} <= set(client.server_info["capabilities"])
        name = f"{NODE}.{PARAMETER}"
        wait_until_seen(client, name)
        mark = client.mark()
        values = client.request("setParameters", parameters=[{"name": name, "value": 7.0}], requestId="c")
        said = client.statuses(mark["statuses"], "")
        assert values["parameters"] == [{"name": name, "value": 7.0, "type": "float64"}], said
        answer = client.request(
            "call", name=f"{NODE}/get_parameters", request=cdr(GetParameters.Request(names=[PARAMETER]))
        )
        from rclpy.serialization import deserialize_message

        response = deserialize_message(base64.b64decode(answer["response"]), GetParameters.Response)
        assert [v.double_value for v in response.values] == [7.0]  # the node's own answer, after the set
    finally:
        client.close()
    log = remote.control.output()
    assert "feeder bridge: WARNING: --allow-remote-control: " in log, log
    assert "--allow-insecure-remote" not in log, log


def test_plain_ws_off_loopback_is_an_explicit_opt_out_warned_at_start(remote: Hosts) -> None:
    assert remote.plain.url.startswith("ws://")
    client = remote.client(remote.plain.url, SUBPROTOCOLS[1], trusted=False)
    client.close()
    log = remote.plain.output()
    assert (
        f"feeder bridge: WARNING: --allow-insecure-remote: plain ws:// on {remote.hosts.a.address}" in log
    ), log
    assert "--allow-remote-control" not in log, log


@pytest.mark.parametrize(
    ("secured", "option"), [(False, "--tls-cert"), (True, "--allow-remote-control")], ids=["plain", "control"]
)
def test_on_a_real_interface_an_unsecured_start_is_refused(remote: Hosts, secured: bool, option: str) -> None:
    a = remote.hosts.a
    tls = ["--tls-cert", str(remote.certificate), "--tls-key", str(remote.key)] if secured else []
    command = [sys.executable, "-m", "feeder_cell.cli.main", "bridge", "--address", a.address, *tls]
    run = subprocess.run(a.command(command), env=remote.env, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and run.stdout == "", (run.returncode, run.stdout, run.stderr)
    assert run.stderr.splitlines() == [run.stderr.strip()], run.stderr  # one line
    assert run.stderr.startswith(f"feeder bridge: {option}: {a.address} is not a loopback address"), (
        run.stderr
    )
