"""The squeeze gripper's ROS message adapters: its streams from the gripper model, and its two goals.

The node (``feeder_sim.nodes.squeeze_gripper``) publishes what these build; ``SqueezeActionGoal`` is the
kit's goal runner's view of the ROS-free ``squeeze.plan_goal.PlanGoal``, for ``~/squeeze`` (one angle)
and ``~/run_plan`` (a sequence) alike: the two actions differ only in their messages.
"""

from __future__ import annotations

import math
from typing import Any, Protocol, Sequence

from geometry_msgs.msg import PoseStamped
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock
from rclpy.impl.rcutils_logger import RcutilsLogger
from sensor_msgs.msg import JointState

from feeder_device.declarations import Counters
from feeder_device.device import DeviceState
from feeder_msgs.action import RunPlan, Squeeze
from feeder_msgs.msg import SqueezeState
from feeder_planner.node_kit import yaw_quaternion
from feeder_sim.node_kit.stamp import header
from feeder_sim.squeeze.gripper import SqueezeGripper
from feeder_sim.squeeze.plan_goal import PlanGoal
from feeder_sim.squeeze.station import SqueezeStation

__all__ = [
    "GripperNode",
    "SqueezeActionGoal",
    "joint_state_msg",
    "part_pose_msg",
    "state_msg",
]


def state_msg(now_ns: int, frame_id: str, gripper: SqueezeGripper) -> SqueezeState:
    """Return ~/state: gripper angle, jaw width (the sensor), the part (ground truth), phase, friction."""
    return SqueezeState(
        header=header(now_ns, frame_id),
        gripper_angle=float(gripper.gripper_angle),
        jaw_width=float(gripper.jaw_width),
        part_orientation=float(gripper.orientation) if gripper.holding else math.nan,
        holding=bool(gripper.holding),
        phase=gripper.phase,
        friction=float(gripper.effective_friction),
    )


def joint_state_msg(now_ns: int, frame_id: str, gripper: SqueezeGripper) -> JointState:
    """Return ~/joint_states: the gripper's turn joint (rad) and the jaw opening joint (m)."""
    return JointState(
        header=header(now_ns, frame_id),
        name=["gripper_turn", "jaw_width"],
        position=[float(gripper.gripper_angle), float(gripper.jaw_width)],
    )


def part_pose_msg(now_ns: int, frame_id: str, gripper: SqueezeGripper) -> PoseStamped:
    """Return ~/part_pose: the part at the gripper's centre, turned by its orientation (ground truth)."""
    msg = PoseStamped(header=header(now_ns, frame_id))
    if gripper.holding:
        msg.pose.orientation = yaw_quaternion(float(gripper.orientation))
    else:
        msg.pose.position.z = math.nan  # no part: a pose a viewer will not draw
    return msg


class GripperNode(Protocol):
    """What ``SqueezeActionGoal`` needs of the gripper node (a protocol: no import of the node module)."""

    gripper: SqueezeGripper | None
    station: SqueezeStation | None
    count: Counters

    def stopping_fault(self) -> tuple[int, str] | None:
        """(code, text) of the fault that stops the device, or None."""
        ...

    def state(self) -> DeviceState:
        """Return the controller-facing state."""
        ...

    def get_clock(self) -> Clock:
        """Return the node clock."""
        ...

    def get_logger(self) -> RcutilsLogger:
        """Return the node's logger."""
        ...


class SqueezeActionGoal:
    """The runner's view of a ``PlanGoal``: its feedback and result as Squeeze or RunPlan messages."""

    def __init__(self, node: GripperNode, goal: PlanGoal, handle: ServerGoalHandle, action: Any) -> None:
        self.node, self.goal, self.handle, self.action = node, goal, handle, action
        self.name = "~/run_plan" if action is RunPlan else "~/squeeze"

    @property
    def done(self) -> bool:
        """Whether the plan goal has ended."""
        return self.goal.done

    def advance(self, now_ns: int) -> None:
        """Take in the tick that is over: the squeezes read, then end or start the next squeeze."""
        station = self.node.station
        if station is None:
            self.goal.end_now("FAULT", "the gripper is not configured", None)
            return
        station.advance_goal(self.goal, now_ns, self.node.stopping_fault())

    def cancel(self, reason: str) -> None:
        """End once the jaws are open again (the squeeze in progress halted)."""
        self.goal.cancel(reason)
        self.advance(self.node.get_clock().now().nanoseconds)

    def halt(self) -> None:
        """Open the jaws where they are (after the guard aborted the goal)."""
        if self.node.gripper is not None:
            self.node.gripper.halt()

    def interrupt(self, reason: str) -> None:
        """End now: the device left active, so no squeeze can go on."""
        state = self.node.state().name
        self.goal.end_now(
            "FAULT",
            f"device {state} (deactivated) during the goal: activate it and send a new goal",
            self.node.gripper,
            0,
            f"device {state}",
        )

    def feedback(self) -> Sequence[Any]:
        """One feedback per phase the gripper entered, in order."""
        reports, self.goal.reports = self.goal.reports, []
        if self.action is RunPlan:
            return [
                RunPlan.Feedback(
                    squeeze=r.squeeze,
                    squeezes_total=r.total,
                    phase=r.phase,
                    jaw_width=r.width,
                    part_orientation=r.orientation,
                )
                for r in reports
            ]
        return [
            Squeeze.Feedback(phase=r.phase, jaw_width=r.width, part_orientation=r.orientation)
            for r in reports
        ]

    def result(self) -> tuple[str, Any]:
        """Return the terminal state and result (the outcome's code and name, the widths read)."""
        outcome = self.goal.outcome
        assert outcome is not None  # the runner asks only once the goal ended
        common = {
            "outcome": outcome.code,
            "outcome_name": outcome.name,
            "message": outcome.message,
            "part_orientation": float(outcome.orientation),
            "fault_code": outcome.fault_code,
            "fault_text": outcome.fault_text,
        }
        if self.action is RunPlan:
            result = RunPlan.Result(squeezes=len(outcome.widths), jaw_widths=list(outcome.widths), **common)
        else:
            width = outcome.widths[0] if outcome.widths else math.nan
            result = Squeeze.Result(jaw_width=float(width), **common)
        log = self.node.get_logger()
        if outcome.name == "DONE":
            if self.action is RunPlan:
                self.node.count.add("plans_done")
            log.info(f"{self.name}: {outcome.name}: {outcome.message}")
            return "succeed", result
        log.warning(f"{self.name}: {outcome.name}: {outcome.message}")
        canceled = outcome.name == "CANCELED" and self.handle.is_cancel_requested
        return ("canceled" if canceled else "abort"), result
