"""``feeder bridge``: serve the live ROS graph to Foxglove over the Foxglove WebSocket protocol."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from feeder_cell.bridge.defaults import DEFAULT_ADDRESS, DEFAULT_PORT
from feeder_cell.ros_session import with_node
from feeder_planner.errors import FeederError, InputError


def _port(text: str) -> int:
    """Argparse type: a TCP port, 0 (any free one) to 65535."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be in [0, 65535], got {value}")
    return value


def _run(args: argparse.Namespace) -> int:
    from feeder_cell.bridge.server import GraphBridge

    if not args.address.strip():
        raise InputError("--address", "must name an interface address, e.g. 127.0.0.1 or 0.0.0.0")

    def work(node: Any, executor: Any, keep_going: Any) -> int:
        try:
            bridge = GraphBridge(node, args.address, args.port)
        except RuntimeError as error:  # foxglove-sdk: the address cannot be bound
            raise FeederError(f"cannot serve ws://{args.address}:{args.port}: {error}") from None
        # The line a user (and a test) waits for: where to point Foxglove.
        sys.stdout.write(f"feeder bridge: serving ws://{args.address}:{bridge.port} (Ctrl-C stops)\n")
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
        description="Serve every topic of the ROS graph (this ROS_DOMAIN_ID) as a Foxglove WebSocket channel "
        "with its ros2msg schema and raw CDR messages; topics appear as they are discovered (checked every "
        "second) and vanish with their publishers. In Foxglove: Open connection, Foxglove WebSocket, "
        "ws://ADDRESS:PORT. Runs until Ctrl-C; exit 1 when the address cannot be served.",
    )
    parser.add_argument(
        "--address", default=DEFAULT_ADDRESS, help=f"interface to listen on (default {DEFAULT_ADDRESS})"
    )
    parser.add_argument(
        "--port",
        type=_port,
        default=DEFAULT_PORT,
        help=f"TCP port (default {DEFAULT_PORT}; 0: any free port)",
    )
    parser.set_defaults(handler=_run)
