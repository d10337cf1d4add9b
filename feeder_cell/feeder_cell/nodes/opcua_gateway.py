"""ROS 2 node: the OPC UA gateway for PLC cell controllers (asyncua server, devices over DDS).

A thin adapter: parameters are read and checked here (``feeder_cell.gateway.config``), the address space
and method calls live in ``feeder_cell.gateway.server`` and the ROS side in ``feeder_cell.gateway.ros_link``.
The asyncua server runs on an asyncio loop in the main thread; rclpy spins in a background thread (see
the ROS link's docstring for the hand-offs). A bad parameter is one FATAL line naming it and exit code 2;
an endpoint that cannot be bound, exit code 2 naming the endpoint. SIGINT or SIGTERM stops it cleanly.
Off loopback it is secure by default (``config.check_security``): Basic256Sha256_SignAndEncrypt with a
certificate made on first start (``certificates``) and users with passwords, or a start refused.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import threading

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from feeder_cell.gateway import layout
from feeder_cell.gateway.certificates import default_pki_dir, ensure_certificate
from feeder_cell.gateway.config import (
    DeviceEntry,
    check_security,
    parse_devices,
    parse_endpoint,
    security_warnings,
)
from feeder_cell.gateway.kinds import KINDS
from feeder_cell.gateway.process import AbandonedCalls, log_to_stderr
from feeder_cell.gateway.roles import parse_role
from feeder_cell.gateway.ros_link import RosLink
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Goal
from feeder_cell.gateway.users import load_users
from feeder_planner.errors import InputError
from feeder_planner.node_kit import ParameterSpec, declare_parameters, positive
from feeder_planner.node_kit.runner import StopRequest
from feeder_planner.parameter_specs import integer_at_least

__all__: list[str] = []

NODE_NAME = "opcua_gateway"
EXIT_BAD_CONFIGURATION = 2


def _strings(value: object) -> str | None:
    ok = isinstance(value, list) and all(isinstance(v, str) for v in value)
    return None if ok else f"must be a list of strings, got {value!r}"


PARAMETERS = (
    ParameterSpec(
        "endpoint",
        "opc.tcp://127.0.0.1:4840",
        "OPC UA endpoint URL the server listens on (opc.tcp://HOST:PORT)",
        read_only=True,
    ),
    ParameterSpec(
        "devices",
        [""],
        "device nodes exposed, each [KIND:]NODE (e.g. /cell/throwing_arm; KIND, one of "
        f"{', '.join(KINDS)}, when the node's name is not its kind)",
        _strings,
        read_only=True,
    ),
    ParameterSpec(
        "security_policies",
        ["None"],
        "endpoints offered: None, Basic256Sha256_Sign, Basic256Sha256_SignAndEncrypt",
        _strings,
        read_only=True,
    ),
    ParameterSpec(
        "certificate_file",
        "",
        "server certificate (DER or PEM) for Basic256Sha256; empty: a self-signed one made in pki_dir",
        read_only=True,
    ),
    ParameterSpec(
        "private_key_file",
        "",
        "server private key (PEM) of certificate_file; empty: made with it in pki_dir",
        read_only=True,
    ),
    ParameterSpec(
        "pki_dir",
        "",
        "folder where the self-signed certificate and key are made on first start and reused; empty: "
        "$ROS_HOME/feeder/opcua_pki (~/.ros/feeder/opcua_pki)",
        read_only=True,
    ),
    ParameterSpec(
        "trusted_certificates_dir",
        "",
        "folder of trusted client certificates (or their CAs; PEM or DER) for the Basic256Sha256 "
        "policies; empty: a certificate of any issuer opens a secure channel (its validity period and URI "
        "are checked either way)",
        read_only=True,
    ),
    ParameterSpec(
        "allow_anonymous", True, "accept anonymous sessions (on a loopback endpoint only)", read_only=True
    ),
    ParameterSpec(
        "anonymous_role",
        "Engineer",
        "the role of an anonymous session: Observer (browse, read, subscribe), Operator (also the devices' "
        "methods and acknowledging alarms) or Engineer (also RunProgram and LoadProgram)",
        read_only=True,
    ),
    ParameterSpec(
        "login_failures",
        5,
        "consecutive failed logins from one client address, or for one user name, before each further "
        "failure locks it out for login_lockout",
        integer_at_least(1),
        read_only=True,
    ),
    ParameterSpec(
        "login_lockout",
        30.0,
        "s (wall) an address or a user name is locked out after a failed login past login_failures",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "allow_anonymous_remote",
        False,
        "also accept anonymous sessions on a non-loopback endpoint (explicitly, logged; refused otherwise)",
        read_only=True,
    ),
    ParameterSpec(
        "allow_insecure_remote",
        False,
        "allow security policy None, or Sign without SignAndEncrypt, on a non-loopback endpoint "
        "(explicitly, logged; refused otherwise)",
        read_only=True,
    ),
    ParameterSpec(
        "users_file",
        "",
        "YAML users file with salted password hashes (python -m feeder_cell.gateway.users NAME); empty: none",
        read_only=True,
    ),
    ParameterSpec(
        "program_dir",
        "",
        "folder of the field program files RunProgram may name (empty: inline only)",
        read_only=True,
    ),
    ParameterSpec(
        "call_timeout",
        10.0,
        "s (wall) a method call waits for the device's answer (a service reply, a goal acceptance)",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "startup_timeout",
        10.0,
        "s (wall) the gateway waits at start for every device's first ~/status and its services and action "
        "before it listens; a device not ready by then is served offline (Status/Online false)",
        positive,
        read_only=True,
    ),
)


def _build(node: Node, executor: SingleThreadedExecutor) -> tuple[GatewayServer, RosLink, float]:
    """Check every parameter and build the server and the ROS link; InputError names the parameter."""
    p = declare_parameters(node, PARAMETERS)
    endpoint = parse_endpoint(p["endpoint"])
    devices = parse_devices(p["devices"])
    security = check_security(
        endpoint,
        p["security_policies"],
        p["certificate_file"],
        p["private_key_file"],
        p["allow_anonymous"],
        p["allow_anonymous_remote"],
        p["users_file"],
        p["trusted_certificates_dir"],
        p["allow_insecure_remote"],
        p["pki_dir"],
    )
    anonymous_role = parse_role(p["anonymous_role"], "parameter anonymous_role")
    security = dataclasses.replace(
        security,
        anonymous_role=anonymous_role,
        login_failures=int(p["login_failures"]),
        login_lockout=float(p["login_lockout"]),
    )
    users = load_users(security.users_file) if security.users_file else None
    if security.makes_certificate:
        made = ensure_certificate(security.pki_dir, layout.APPLICATION_URI, endpoint.host)
        security = dataclasses.replace(
            security, certificate_file=made.certificate_file, private_key_file=made.private_key_file
        )
        # The thumbprint is what an operator compares when a PLC asks whether to trust this server.
        node.get_logger().info(
            f"{'made a self-signed' if made.created else 'reusing the'} server certificate "
            f"{made.certificate_file} (key {made.private_key_file}; pki_dir "
            f"{security.pki_dir or default_pki_dir()}): SHA-1 {made.sha1}, SHA-256 {made.sha256}"
        )
    logger = logging.getLogger(NODE_NAME)
    holder: dict[str, RosLink] = {}

    class _Handler:
        async def call(self, device: DeviceEntry, method: str, goal: Goal | None) -> tuple[str, str]:
            return await holder["ros"].call(device, method, goal)

    server = GatewayServer(endpoint, security, users, devices, _Handler(), p["program_dir"], logger)
    ros = RosLink(node, executor, server, float(p["call_timeout"]))
    holder["ros"] = ros
    return server, ros, float(p["startup_timeout"])


async def _serve(
    node: Node, server: GatewayServer, ros: RosLink, startup_timeout: float, stop_request: StopRequest
) -> int:
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()

    def wake(_: object) -> None:
        # From the signal handler or the stop watcher's thread, possibly as the loop closes.
        with contextlib.suppress(RuntimeError):
            loop.call_soon_threadsafe(stop.set)

    stop_request.future.add_done_callback(wake)
    if stop_request.requested:
        return 0  # stopped while it was being built: nothing was served
    # Listening means ready: a PLC's first command must not race the devices' discovery.
    missing = await ros.health.wait_for_devices(startup_timeout, stop)
    if stop.is_set():
        return 0
    for device, gaps in missing.items():
        node.get_logger().warning(
            f"{device}: not ready within startup_timeout {startup_timeout:g} s (lacks {', '.join(gaps)}); "
            "served with Status/Online as heard, its commands refused until it reports"
        )
    # The start is raced against the stop: asyncua builds its standard address space in a thread for
    # seconds of CPU on a loaded machine (2-3 s beside two busy processes, more in CI), and a stop that
    # waited for it ended the node 10-12 s after Ctrl-C. A start cut short is abandoned (_AbandonedCalls).
    starting = asyncio.ensure_future(server.start())
    stopping = asyncio.ensure_future(stop.wait())
    await asyncio.wait({starting, stopping}, return_when=asyncio.FIRST_COMPLETED)
    if not starting.done():
        starting.cancel()
        with contextlib.suppress(asyncio.CancelledError, OSError):
            await starting
        await server.stop()
        return 0
    stopping.cancel()
    error = starting.exception()
    if isinstance(error, OSError):
        node.get_logger().fatal(
            f"parameter endpoint: cannot listen on {server.endpoint.url}: {error.strerror or error}"
        )
        return EXIT_BAD_CONFIGURATION
    if error is not None:
        raise error
    for warning in security_warnings(server.endpoint, server.security):
        node.get_logger().warning(warning)
    names = ", ".join(d.node for d in server.devices) or "no devices"
    security = server.security
    anonymous = f"allowed, {security.anonymous_role.name}" if security.allow_anonymous else "refused"
    node.get_logger().info(
        f"OPC UA server on {server.endpoint.url} ({', '.join(server.security.policies)}; "
        f"anonymous {anonymous}; "
        f"users {'from ' + server.security.users_file if server.users else 'none'}): {names}"
    )
    await stop.wait()
    await server.stop()
    return 0


def main(args: list[str] | None = None) -> None:
    """Run the opcua_gateway node until SIGINT or SIGTERM (exit 0, whichever phase the signal came in)."""
    # The stop signals only complete a stop request (node_kit.runner.StopRequest, as for every other
    # node), taken from before rclpy's start: rclpy's handlers would end the context under a running
    # server, and Python's would raise KeyboardInterrupt wherever the main thread was (the build, the
    # clean-up). The asyncio loop hears the request through a done callback.
    stop = StopRequest().install()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    log_to_stderr(NODE_NAME)
    node = rclpy.create_node(NODE_NAME)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        server, ros, startup_timeout = _build(node, executor)
    except InputError as error:
        node.get_logger().fatal(f"bad configuration: {error}")
        stop.ignore_from_now()
        node.destroy_node()
        rclpy.try_shutdown()
        raise SystemExit(EXIT_BAD_CONFIGURATION) from None

    def spin() -> None:
        try:
            executor.spin()
        except ExternalShutdownException:
            pass

    thread = threading.Thread(target=spin, name="rclpy", daemon=True)
    thread.start()
    code = 1
    try:
        with asyncio.Runner() as runner:
            runner.get_loop().set_default_executor(AbandonedCalls())
            code = runner.run(_serve(node, server, ros, startup_timeout, stop))
    finally:
        stop.ignore_from_now()
        executor.shutdown(timeout_sec=2.0)
        thread.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown()
    if code:
        raise SystemExit(code)


if __name__ == "__main__":
    main()
