"""``feeder call`` and ``feeder send-goal``: call a service or send an action goal from a shell.

What ``ros2 service call`` and ``ros2 action send_goal`` do on a full install (ros2cli is not on the
registry): the request or goal from YAML (``'{fault: motor_fault}'``), the answer printed as YAML-like
lines or one JSON object. ``call`` exits 0 once answered (1 when the response's ``ok`` or ``success``
field is false: refused); ``send-goal`` exits 0 when the goal
SUCCEEDED and 1 when it was rejected, aborted or canceled, printing the result either way.
"""

from __future__ import annotations

import argparse
import json
import threading
import time
from typing import Any, Callable

from feeder_cell.cli.common import add_json_flag, emit
from feeder_cell.cli.messages import from_yaml, import_type, to_plain
from feeder_cell.ros_session import with_node
from feeder_planner.errors import FeederError, InputError

STATUS_NAMES = {4: "SUCCEEDED", 5: "CANCELED", 6: "ABORTED"}


def _name(text: str, field: str) -> str:
    name = text.strip()
    if not name or any(c.isspace() for c in name):
        raise InputError(field, f"expected a name such as /throwing_arm/inject_fault, got {text!r}")
    return name if name.startswith("/") else f"/{name}"


def _wait(event: threading.Event, executor: Any, keep_going: Callable[[], bool], deadline: float) -> bool:
    while not event.is_set() and keep_going() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    return event.is_set()


def _lines(data: Any, indent: str = "") -> list[str]:
    """YAML-like lines of plain data (what ros2 prints)."""
    if isinstance(data, dict):
        out: list[str] = []
        for key, value in data.items():
            if isinstance(value, dict) and value:
                out += [f"{indent}{key}:", *_lines(value, indent + "  ")]
            else:
                out.append(f"{indent}{key}: {json.dumps(value)}")
        return out
    return [f"{indent}{json.dumps(data)}"]


def _call(args: argparse.Namespace) -> int:
    service = _name(args.service, "SERVICE")
    srv = import_type(args.type, "srv")
    request = from_yaml(srv.Request, args.values)

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        client = node.create_client(srv, service)
        deadline = time.monotonic() + args.timeout
        while not client.service_is_ready():
            if time.monotonic() > deadline or not keep_going():
                raise FeederError(f"{service}: no such service after {args.timeout:g} s (not running?)")
            executor.spin_once(timeout_sec=0.05)
        answered = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: answered.set())
        if not _wait(answered, executor, keep_going, time.monotonic() + args.timeout):
            raise FeederError(f"{service}: no answer within {args.timeout:g} s")
        return {"service": service, "response": to_plain(future.result())}

    result = with_node("feeder_call", work)
    emit(args, result, lambda r: "\n".join(_lines(r["response"])))
    # The project's responses say whether the request was carried out (ok, or std_srvs' success): a shell
    # script must see a refusal in the exit status.
    refused = any(result["response"].get(key) is False for key in ("ok", "success"))
    return 1 if refused else 0


def _send_goal(args: argparse.Namespace) -> int:
    from feeder_planner.node_kit.action_client import ActionClient

    action_name = _name(args.action, "ACTION")
    action = import_type(args.type, "action")
    goal = from_yaml(action.Goal, args.values)

    def work(node: Any, executor: Any, keep_going: Callable[[], bool]) -> dict[str, Any]:
        client = ActionClient(node, action, action_name)
        deadline = time.monotonic() + args.timeout
        while not client.server_is_ready():
            if time.monotonic() > deadline or not keep_going():
                raise FeederError(f"{action_name}: no such action server after {args.timeout:g} s")
            executor.spin_once(timeout_sec=0.05)
        feedback: list[Any] = []

        def on_feedback(message: Any) -> None:
            feedback.append(to_plain(message.feedback))
            if args.feedback and not args.json:
                print("feedback: " + json.dumps(feedback[-1]), flush=True)

        accepted = threading.Event()
        sent = client.send_goal_async(goal, feedback_callback=on_feedback)
        sent.add_done_callback(lambda _: accepted.set())
        if not _wait(accepted, executor, keep_going, time.monotonic() + args.timeout):
            raise FeederError(f"{action_name}: the goal was not answered within {args.timeout:g} s")
        handle = sent.result()
        if not handle.accepted:
            return {"action": action_name, "status": "REJECTED", "feedback": feedback, "result": None}
        done = threading.Event()
        result_future = handle.get_result_async()
        result_future.add_done_callback(lambda _: done.set())
        while not done.is_set() and keep_going():
            executor.spin_once(timeout_sec=0.05)
        if not done.is_set():  # Ctrl-C: cancel the goal, as ros2 action send_goal does
            handle.cancel_goal_async()
            executor.spin_once(timeout_sec=0.5)
            raise KeyboardInterrupt
        answer = result_future.result()
        status = STATUS_NAMES.get(int(answer.status), f"status {answer.status}")
        return {
            "action": action_name,
            "status": status,
            "feedback": feedback,
            "result": to_plain(answer.result),
        }

    result = with_node("feeder_send_goal", work)

    def summary(r: dict[str, Any]) -> str:
        lines = [
            f"goal {r['status']}"
            + (f" after {len(r['feedback'])} feedback messages" if r["feedback"] else "")
        ]
        return "\n".join(lines + (_lines(r["result"]) if r["result"] is not None else []))

    emit(args, result, summary)
    return 0 if result["status"] == "SUCCEEDED" else 1


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    call = subparsers.add_parser(
        "call",
        help="call a service (as 'ros2 service call')",
        description="Call SERVICE of type TYPE (package/srv/Name) with the request's fields from VALUES "
        "(YAML, e.g. '{fault: motor_fault}'); print the response. Exit 1 when no server answers or the "
        "response's ok (or success) field is false, 2 for a bad type or field.",
    )
    call.add_argument("service", help="service name, e.g. /throwing_arm/inject_fault")
    call.add_argument("type", help="service type, e.g. feeder_msgs/srv/InjectFault")
    call.add_argument(
        "values", nargs="?", default="", help="the request's fields as YAML (default: all defaults)"
    )
    call.add_argument(
        "--timeout", type=float, default=10.0, help="wall seconds to wait for the server and answer"
    )
    add_json_flag(call)
    call.set_defaults(handler=_call)
    goal = subparsers.add_parser(
        "send-goal",
        help="send an action goal and wait for its result (as 'ros2 action send_goal')",
        description="Send a goal to ACTION of type TYPE (package/action/Name) with its fields from VALUES "
        "(YAML); wait for the result and print it (Ctrl-C cancels the goal). Exit 0 when the goal "
        "SUCCEEDED, 1 when it was rejected, aborted or canceled or no server answers, 2 for bad input.",
    )
    goal.add_argument("action", help="action name, e.g. /throwing_arm/feed_part")
    goal.add_argument("type", help="action type, e.g. feeder_msgs/action/FeedPart")
    goal.add_argument(
        "values", nargs="?", default="", help="the goal's fields as YAML (default: all defaults)"
    )
    goal.add_argument("--feedback", action="store_true", help="print each feedback message as it comes")
    goal.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        help="wall seconds to wait for the server and the goal's acceptance",
    )
    add_json_flag(goal)
    goal.set_defaults(handler=_send_goal)
