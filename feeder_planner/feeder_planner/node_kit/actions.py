"""Action servers of managed devices: goals checked at goal time, one at a time, advanced by the ticks.

A device's long operations (feed a part, run a field program, follow a path) are ROS 2 actions beside the
services that start them without feedback. The conventions every device keeps, in one place:

- **Checked at goal time.** The goal callback asks the device whether it is ready (not FAULT, STOPPED or
  inactive) and validates the goal with the device's own check, which raises a ``FeederError`` naming the
  field. A refused goal is REJECTED at once (the client's ``accepted`` is false, nothing moved); ROS 2 has
  no field for the reason, so the device logs it at WARN on ``/rosout`` and shows the last one in its
  ``/diagnostics`` (``last_goal_rejection``).
- **One goal at a time** per action: a second goal while one executes is rejected naming the first. A
  controller that wants to preempt cancels first (hardware does not queue motion goals silently).
- **Advanced by the device's ticks.** ``execute`` is a coroutine that awaits ``device.next_tick()`` and
  reads the model after each tick, so a goal moves with the node clock (a held ``/clock`` holds the goal,
  lockstep runs are deterministic) and never blocks the executor. Deactivation wakes every waiter so that
  no goal outlives the device's activity: ``execute`` must end its goal when ``device.active`` is false.
- **Cancel is always accepted**; ``execute`` decides where the device can safely stop.
"""

from __future__ import annotations

from typing import Any, Awaitable, Callable

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle

from feeder_planner.errors import FeederError
from feeder_planner.node_kit.device import ManagedDevice
from feeder_planner.node_kit.qos import request_qos
from feeder_planner.node_kit.services import request_queue_depth

__all__ = ["serve_device_action"]

Validate = Callable[[Any], None]
Execute = Callable[[ServerGoalHandle], Awaitable[Any]]


def serve_device_action(
    device: ManagedDevice, action_type: Any, name: str, validate: Validate, execute: Execute
) -> ActionServer:
    """Create the device's action server ``name`` (a private name such as ``~/feed_part``).

    ``validate(goal)`` raises a ``FeederError`` naming the bad field; ``execute(goal_handle)`` runs the
    accepted goal (see the module docstring) and returns the result message, having called
    ``succeed``, ``abort`` or ``canceled`` on the handle.
    """
    # Counted from acceptance, not from execution: two goals sent together must not both be accepted.
    goals = [0]

    def on_goal(goal: Any) -> GoalResponse:
        try:
            device.require_ready(f"{name} goal")
            if goals[0]:
                raise FeederError(f"{name} goal refused: a goal is executing; cancel it first")
            validate(goal)
        except FeederError as error:
            device.record_goal_rejection(name, str(error))
            return GoalResponse.REJECT
        goals[0] += 1
        return GoalResponse.ACCEPT

    async def on_execute(goal_handle: ServerGoalHandle) -> Any:
        try:
            return await execute(goal_handle)
        finally:
            goals[0] -= 1
            device.publish_status()

    def on_cancel(goal_handle: ServerGoalHandle) -> CancelResponse:
        return CancelResponse.ACCEPT

    # Goal, cancel and result requests queue as deep as the device's services (node_kit.services).
    queue = request_qos(request_queue_depth(device))
    return ActionServer(
        device,
        action_type,
        name,
        execute_callback=on_execute,
        goal_callback=on_goal,
        cancel_callback=on_cancel,
        goal_service_qos_profile=queue,
        result_service_qos_profile=queue,
        cancel_service_qos_profile=queue,
    )
