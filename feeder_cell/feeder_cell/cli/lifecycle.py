"""``feeder lifecycle NODE [TRANSITION]``: get or change a managed node's state (as ``ros2 lifecycle``)."""

from __future__ import annotations

import argparse
from typing import Any, Callable

from feeder_cell.cli.common import add_json_flag, emit
from feeder_cell.lifecycle_client import TRANSITIONS, LifecycleClient, LifecycleError
from feeder_cell.ros_session import with_node
from feeder_planner.errors import InputError

# How long to wait for the node's lifecycle services to appear in the graph before saying it is absent.
DISCOVERY_TIMEOUT_S = 5.0


def _node_name(text: str) -> str:
    name = text.strip()
    if not name or any(c.isspace() for c in name):
        raise InputError("NODE", f"expected a node name such as /cell/feeder_a/throwing_arm, got {text!r}")
    return name if name.startswith("/") else f"/{name}"


def _run(args: argparse.Namespace) -> int:
    target = _node_name(args.node)

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        client = LifecycleClient(node, executor, target)
        if not client.is_managed(DISCOVERY_TIMEOUT_S):
            raise LifecycleError(
                f"{target}: no lifecycle services after {DISCOVERY_TIMEOUT_S:.0f} s "
                "(not running, or not a managed node)"
            )
        before = client.get_state()
        if args.transition == "get":
            return {"node": target, "state": before}
        return {
            "node": target,
            "transition": args.transition,
            "from": before,
            "state": client.change(args.transition),
        }

    result = with_node("feeder_lifecycle", work)  # a refusal is a LifecycleError: exit 1, one line
    emit(
        args,
        result,
        lambda r: (
            f"{r['node']}: {r['state']}"
            + (f" (after {r['transition']} from {r['from']})" if "transition" in r else "")
        ),
    )
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    parser = subparsers.add_parser(
        "lifecycle",
        help="get the lifecycle state of a managed node, or drive one transition",
        description="Drive one managed node through the standard lifecycle_msgs services (as "
        "'ros2 lifecycle' does on a full install). Exit 1 when the node refuses the transition or is not "
        "found.",
    )
    parser.add_argument("node", help="fully qualified node name, e.g. /cell/feeder_a/throwing_arm")
    parser.add_argument(
        "transition",
        nargs="?",
        default="get",
        choices=["get", *TRANSITIONS],
        help="get (default) or a transition",
    )
    add_json_flag(parser)
    parser.set_defaults(handler=_run)
