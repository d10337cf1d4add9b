"""``feeder bridge``: serve the live ROS graph to Foxglove over the Foxglove WebSocket protocol."""

from __future__ import annotations

import argparse
import math
import re
import sys
from typing import TYPE_CHECKING, Callable

from feeder_cell.bridge.defaults import (
    DEFAULT_ADDRESS,
    DEFAULT_CLIENT_TOPICS,
    DEFAULT_PORT,
    DEFAULT_SERVICE_TIMEOUT,
)
from feeder_cell.bridge.security import check_bridge_security
from feeder_cell.ros_session import with_node
from feeder_planner.errors import FeederError, InputError

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node


def _port(text: str) -> int:
    """Argparse type: a TCP port, 0 (any free one) to 65535."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be in [0, 65535], got {value}")
    return value


def _pattern(text: str) -> str:
    """Argparse type: a regular expression a whole topic name must match."""
    try:
        re.compile(text)
    except re.error as error:
        raise argparse.ArgumentTypeError(f"not a regular expression: {error}") from None
    return text


def _seconds(text: str) -> float:
    """Argparse type: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text}")
    return value


def _run(args: argparse.Namespace) -> int:
    from feeder_cell.bridge.server import GraphBridge

    if not args.address.strip():
        raise InputError("--address", "must name an interface address, e.g. 127.0.0.1 or 0.0.0.0")
    # Checked before ROS starts: a refused start is one line, and no node appears in the graph.
    security = check_bridge_security(
        args.address,
        args.tls_cert,
        args.tls_key,
        args.read_only,
        args.allow_insecure_remote,
        args.allow_remote_control,
    )
    for warning in security.warnings:  # every start, so a log never hides an opt-out
        sys.stderr.write(f"feeder bridge: WARNING: {warning}\n")
    sys.stderr.flush()

    def work(node: Node, executor: Executor, keep_going: Callable[[], bool]) -> int:
        try:
            bridge = GraphBridge(
                node,
                args.address,
                args.port,
                read_only=args.read_only,
                client_topics=tuple(args.client_topic or DEFAULT_CLIENT_TOPICS),
                service_timeout=args.service_timeout,
                tls=security.tls,
            )
        except OSError as error:  # the address cannot be bound (in use, not this machine's)
            raise FeederError(
                f"cannot serve {security.scheme}://{args.address}:{args.port}: {error}"
            ) from None
        # The line a user (and a test) waits for: where to point Foxglove.
        mode = " read-only" if args.read_only else ""
        host = f"[{args.address}]" if ":" in args.address else args.address  # an IPv6 address in a URL
        sys.stdout.write(
            f"feeder bridge: serving {security.scheme}://{host}:{bridge.port}{mode} (Ctrl-C stops)\n"
        )
        sys.stdout.flush()
        try:
            while keep_going():
                executor.spin_once(timeout_sec=0.1)
        finally:
            bridge.close()
        return 0

    return with_node("feeder_bridge", work)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    parser = subparsers.add_parser(
        "bridge",
        help="serve the live ROS graph to Foxglove (Foxglove WebSocket protocol)",
        description="Serve the ROS graph (this ROS_DOMAIN_ID) over the Foxglove WebSocket protocol, under "
        "both subprotocol names (foxglove.websocket.v1 and foxglove.sdk.v1) on one port: every topic a "
        "channel with its ros2msg schema and raw CDR messages (checked every second; topics vanish with "
        "their publishers); "
        "every service callable (capability services); node parameters read, set and followed (parameters, "
        "parametersSubscribe, names /node.parameter); publishing from the app on allowed topics "
        "(clientPublish); the connection graph (connectionGraph); and, for a client that connects while a "
        "cell clock publishes /clock, cell time (time). In Foxglove: Open connection, Foxglove WebSocket, "
        "ws://ADDRESS:PORT (wss:// with --tls-cert and --tls-key). Off loopback it is secure by default: it "
        "refuses to start without TLS (unless --allow-insecure-remote) and with control (services, "
        "parameter sets, publishing) unless --read-only or --allow-remote-control; each opt-out is a "
        "WARNING at every start. Runs until Ctrl-C; exit 1 when the address cannot be served, 2 on bad "
        "options or certificates.",
    )
    parser.add_argument(
        "--address",
        default=DEFAULT_ADDRESS,
        help=f"interface to listen on (default {DEFAULT_ADDRESS}; any other than loopback needs TLS and "
        "--read-only or --allow-remote-control)",
    )
    parser.add_argument(
        "--port",
        type=_port,
        default=DEFAULT_PORT,
        help=f"TCP port (default {DEFAULT_PORT}; 0: any free port)",
    )
    parser.add_argument(
        "--read-only",
        action="store_true",
        help="refuse clients everything that acts: service calls, parameter sets and publishing (topics, "
        "parameters and the graph stay readable)",
    )
    parser.add_argument(
        "--tls-cert",
        metavar="FILE",
        help="serve wss:// (TLS) with this PEM certificate (chain); needs --tls-key",
    )
    parser.add_argument("--tls-key", metavar="FILE", help="the unencrypted PEM private key of --tls-cert")
    parser.add_argument(
        "--allow-insecure-remote",
        action="store_true",
        help="off loopback, serve plain ws:// without TLS (refused otherwise; a WARNING at every start)",
    )
    parser.add_argument(
        "--allow-remote-control",
        action="store_true",
        help="off loopback, let clients call services, set parameters and publish (refused otherwise "
        "unless --read-only; a WARNING at every start)",
    )
    parser.add_argument(
        "--client-topic",
        action="append",
        type=_pattern,
        metavar="REGEX",
        help="a topic clients may publish on, as a regular expression the whole name matches; repeat for "
        "more; replaces the default, the command topics (last name segment command, commands or cmd, alone "
        f"or joined with underscores, e.g. /cell/station/command, /cmd_vel): {DEFAULT_CLIENT_TOPICS[0]}",
    )
    parser.add_argument(
        "--service-timeout",
        type=_seconds,
        default=DEFAULT_SERVICE_TIMEOUT,
        metavar="SECONDS",
        help=f"a service call without a response after this fails (default {DEFAULT_SERVICE_TIMEOUT:g} s)",
    )
    parser.set_defaults(handler=_run)
