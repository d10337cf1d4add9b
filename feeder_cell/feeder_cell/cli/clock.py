"""``feeder clock``: hold, run or step the cell clock (`cell_clock`) from a shell."""

from __future__ import annotations

import argparse
import math
import time
from typing import Any, Callable

from feeder_cell.cli.common import add_json_flag, emit, finite_float
from feeder_cell.ros_session import with_node
from feeder_planner.errors import FeederError, InputError

# How long to wait for the clock's services to be discovered and to answer.
CALL_TIMEOUT_S = 10.0


def _call(node: Any, executor: Any, srv_type: Any, name: str, request: Any) -> Any:
    client = node.create_client(srv_type, name)
    if not client.wait_for_service(timeout_sec=CALL_TIMEOUT_S):
        raise FeederError(
            f"{name}: no such service after {CALL_TIMEOUT_S:.0f} s (is the cell clock running?)"
        )
    future = client.call_async(request)
    deadline = time.monotonic() + CALL_TIMEOUT_S
    while not future.done():
        if time.monotonic() > deadline:
            raise FeederError(f"{name}: no answer within {CALL_TIMEOUT_S:.0f} s")
        executor.spin_once(timeout_sec=0.05)
    return future.result()


def _run(args: argparse.Namespace) -> int:
    from builtin_interfaces.msg import Duration
    from std_srvs.srv import Trigger

    from feeder_msgs.srv import StepClock

    clock = args.node.rstrip("/") or "/cell_clock"
    if args.action == "step":
        if args.duration is None or not args.duration > 0 or not math.isfinite(args.duration):
            raise InputError("DURATION", f"step needs a duration > 0 s, got {args.duration}")

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        if args.action in ("pause", "resume"):
            response = _call(node, executor, Trigger, f"{clock}/{args.action}", Trigger.Request())
            if not response.success:
                raise FeederError(f"{clock}: {args.action} refused: {response.message}")
            return {"clock": clock, "action": args.action, "message": response.message}
        nanoseconds = int(round(args.duration * 1e9))
        request = StepClock.Request(duration=Duration(sec=nanoseconds // 10**9, nanosec=nanoseconds % 10**9))
        response = _call(node, executor, StepClock, f"{clock}/step", request)
        if not response.ok:
            raise FeederError(f"{clock}: step refused: {response.error}")
        return {"clock": clock, "action": "step", "now": response.now.sec + response.now.nanosec * 1e-9}

    result = with_node("feeder_clock", work)
    emit(
        args, result, lambda r: f"{r['clock']}: " + (f"now {r['now']:.9f} s" if "now" in r else r["message"])
    )
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    parser = subparsers.add_parser(
        "clock",
        help="pause, resume or step the cell clock started by 'feeder launch --real-time-factor'",
        description="Hold the whole cell still (pause), run it again (resume), or advance a paused clock by "
        "DURATION simulated seconds (step). Exit 1 when the clock refuses or is not running.",
    )
    parser.add_argument("action", choices=["pause", "resume", "step"])
    parser.add_argument("duration", nargs="?", type=finite_float, help="seconds to step (step only)")
    parser.add_argument("--node", default="/cell_clock", help="the clock node (default /cell_clock)")
    add_json_flag(parser)
    parser.set_defaults(handler=_run)
