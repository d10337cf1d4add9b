"""A device's long action from the gateway: the goal sent, its rejection explained, its feedback and end.

Separate from the commands and service methods because a goal outlives its method call: the call returns
once the goal is accepted, and its progress and end reach the variables later, from rclpy's callbacks.
``send`` and the callbacks run in the executor's thread, ``rejection`` on the asyncio loop; each reads and
writes the ``DeviceLink`` under the link's lock only, and posts after releasing it, except a goal's
feedback: its clearing at acceptance and the feedback itself decide and post under the lock, so that a
feedback that came before the acceptance was handled (a short goal, a loaded machine: a PLC read the
progress of a finished FollowPath as 0) is not replaced by the cleared values; and a goal's feedback
that comes after its result, when the result already settled the feedback variables
(``ActionLink.final_feedback``), is not posted over them.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

from rclpy.action.client import ClientGoalHandle

from feeder_cell.gateway.device_link import DeviceLink, executing
from feeder_cell.gateway.server import GatewayServer
from feeder_cell.gateway.spec import Goal, Values
from feeder_planner.node_kit.action_client import ActionClient

__all__ = ["REJECTION_WAIT", "GoalRunner"]

# How long a rejected goal waits for the device's reason on /rosout (logged just before it answers).
REJECTION_WAIT = 2.0


class GoalRunner:
    """Sends the goals of a device's action method and posts their progress and end."""

    def __init__(self, server: GatewayServer) -> None:
        self.server = server

    def _post_all(self, link: DeviceLink, values: Values, stamp_ns: int = 0) -> None:
        self.server.post_all(link.entry.key, values, stamp_ns)

    async def send(self, link: DeviceLink, method: str, goal: Goal | None) -> tuple[str, str]:
        """Send the goal (executor thread); ("BadInvalidState", "rejected") when the device rejects it."""
        client: ActionClient = link.action
        if not client.server_is_ready():
            return "BadCommunicationError", f"{method}: the device's action server is not available"
        with link.lock:
            link.rejections.clear()
        if goal is None:
            raise TypeError(f"{method}: not a goal")
        token = object()  # this goal's, for its feedback
        handle = await client.send_goal_async(
            goal.message(), feedback_callback=lambda m: self._feedback(link, token, m)
        )
        if not handle.accepted:
            return "BadInvalidState", "rejected"
        with link.lock:
            link.goal = handle
            link.goals += 1
            goals = link.goals
            # The device's status already shows it executing (the MEMS array while parts move): Busy now;
            # else with the status that shows it (device_listener), in the same publish as the state change.
            link.busy_shown = link.state is not None and executing(link.state, link.busy)
            busy = link.busy_shown
            values: Values = {
                "Command.Action": method,
                "Command.GoalCount": goals,
                "Command.LastOutcome": "",  # cleared: the new goal has none yet
                "Command.LastOutcomeCode": 0,
                "Command.Result.FaultCode": 0,
            }
            if link.feedback_of is not token:
                # The previous goal's progress would read as this one's until the first feedback arrives.
                values.update(link.profile.action.feedback_values(link.profile.action.action_type.Feedback()))
            if busy:
                values["Command.Busy"] = True
            self._post_all(link, values)  # under the lock: see the module's docstring
        handle.get_result_async().add_done_callback(lambda f: self._on_result(link, handle, token, f))
        return "Good", f"{method} goal accepted; Command.Busy shows it executing, Command.LastOutcome its end"

    async def rejection(self, link: DeviceLink, method: str) -> tuple[str, str]:
        """Say why the device rejected a goal: its /rosout line, or its /diagnostics last_goal_rejection."""
        deadline = time.monotonic() + REJECTION_WAIT
        reason = ""
        while time.monotonic() < deadline:
            with link.lock:
                if link.rejections:
                    reason = link.rejections[-1][1].split("goal rejected:", 1)[1].strip()
                    break
            await asyncio.sleep(0.05)
        if not reason:
            with link.lock:
                last = link.diagnosed_rejection
            reason = (
                f"no reason on /rosout; the device's last in /diagnostics: {last}"
                if last
                else "no reason received"
            )
        # Typed, not read from the reason's words: a device that is not ready, or runs another client's
        # goal, refused it for its state; a ready, free device refused the goal's contents.
        with link.lock:
            not_free = not link.ready or not link.online or link.goals_active
        return (
            "BadInvalidState" if not_free else "BadInvalidArgument"
        ), f"{method} rejected by the device: {reason}"

    def _feedback(self, link: DeviceLink, token: object, message: Any) -> None:
        with link.lock:
            if link.settled_by_result is token:
                return  # older than the final feedback its result posted
            link.feedback_of = token
            self._post_all(link, link.profile.action.feedback_values(message.feedback))

    def _on_result(self, link: DeviceLink, handle: ClientGoalHandle, token: object, future: Any) -> None:
        with link.lock:
            if link.goal is not handle:
                return  # already ended (the device went offline)
            link.goal = None
        try:
            result = future.result().result
        except Exception as error:  # noqa: BLE001 - reported in the variables, the gateway keeps serving
            self.finish(link, "LOST", 0, f"no result: {type(error).__name__}: {error}")
            return
        action = link.profile.action
        values = {**action.result_values(result), "Command.Result.FaultCode": int(result.fault_code)}
        if action.final_feedback is not None:
            values.update(action.final_feedback(result))
            with link.lock:
                link.settled_by_result = token
        self.finish(link, result.outcome_name, int(result.outcome), result.message, values)

    def finish(
        self, link: DeviceLink, outcome: str, code: int, message: str, result: Values | None = None
    ) -> None:
        """Post a goal's end in one publish: its result variables, outcome, ResultCount and Busy false."""
        with link.lock:
            link.results += 1
            results = link.results
            link.busy_shown = False
        self._post_all(
            link,
            {
                **(result or {}),
                "Command.LastOutcome": outcome,
                "Command.LastOutcomeCode": code,
                "Command.LastMessage": message,
                "Command.ResultCount": results,
                "Command.Busy": False,
            },
        )
