"""ORIENT on the squeeze gripper (``orienter: squeeze``): a part between its jaws, the planner's plan run.

The plan is asked of the squeeze planner's ``~/plan`` once (it orients every initial orientation, Goldberg
1993, so every cycle runs the same one); ``~/place_part`` puts a new part between the open jaws;
``~/run_plan`` squeezes at the plan's angles. After a reset the gripper opens its jaws before it takes a
part: RECOVER waits for a ``~/state`` stamped after the reset that says IDLE (``wait_jaws_open``).
"""

from __future__ import annotations

import math
from typing import Any

from rclpy.node import Node
from rclpy.task import Future

from feeder_cell.controller import CellMachine, Outcome
from feeder_cell.controller_ros.link import DeviceLink
from feeder_msgs.action import RunPlan
from feeder_msgs.msg import Part as PartMsg
from feeder_msgs.msg import SqueezeState
from feeder_msgs.srv import SqueezePlacePart, SqueezePlanCompute
from feeder_planner.node_kit import STREAM_DEPTH
from feeder_planner.node_kit.action_client import ActionClient

__all__ = ["PLAN_CALLS", "SqueezeStation"]

PLAN_CALLS = 3  # a fresh server may drop its first reply: the plan request is idempotent, sent again


class SqueezeStation:
    """The squeeze gripper's and its planner's clients, the plan, and the ORIENT and RECOVER steps."""

    def __init__(self, node: Node, link: DeviceLink, machine: CellMachine, part: PartMsg) -> None:
        self.node = node
        self.link = link
        self.machine = machine
        self.part = part  # the planner plans for it (squeeze_part_file)
        station = link.devices["squeeze"]
        self.run_plan = ActionClient(node, RunPlan, f"{station}/run_plan")
        self.place_part = node.create_client(SqueezePlacePart, f"{station}/place_part")
        self.planner = node.create_client(SqueezePlanCompute, f"{link.p['squeeze_planner']}/plan")
        self.plan_angles: list[float] | None = None  # the squeeze planner's plan, asked for once
        self.plan_answer: SqueezePlanCompute.Response | None = None
        self.jaws_open: tuple[int, Future] | None = None  # (after ns, completed by a ~/state saying IDLE)
        node.create_subscription(SqueezeState, f"{station}/state", self._on_state, STREAM_DEPTH)
        self.squeezes = 0  # squeezes the plans of this cycle completed

    def orient(self) -> Outcome:
        """Orient on the squeeze gripper: a new part between its jaws, then the squeeze planner's plan.

        A retry runs the plan again on the part where it lies (after a dropped part, RECOVER has placed
        a new one).
        """
        p = self.link.p
        if self.plan_angles is None:
            planned = self._plan()
            if planned is not None:
                return planned
        if self.machine.attempts == 0:
            placed = self.place()
            if placed is not None:
                return placed
        assert self.plan_angles is not None
        goal = RunPlan.Goal(angles=self.plan_angles, timeout=p["squeeze_timeout"])
        result = self.link.action("squeeze", self.run_plan, "run_plan", goal, p["squeeze_timeout"])
        if isinstance(result, Outcome):
            return result
        self.squeezes += result.squeezes
        message = f"{result.squeezes} squeezes; {result.message}"
        if result.outcome_name == "DONE" and self.plan_answer is not None:
            # Ground truth (the gripper reports it for logging): how far the plan left the part from its
            # final orientation, modulo the symmetry period.
            error = math.remainder(
                result.part_orientation - self.plan_answer.final_orientation,
                self.plan_answer.symmetry_period,
            )
            widths = ", ".join(f"{w:.6g}" for w in result.jaw_widths)
            message = (
                f"{result.squeezes} squeezes, jaw widths [{widths}] m, part at "
                f"{result.part_orientation:.6f} rad ({error:+.2e} rad from the plan's final orientation)"
            )
            self.node.get_logger().info(
                f"cycle {self.machine.cycle}: ORIENT on the squeeze gripper: {message}"
            )
        return Outcome(result.outcome_name, result.fault_code, message)

    def _plan(self) -> Outcome | None:
        """Ask the squeeze planner for the plan of the gripper's part; an Outcome if there is none."""
        request = SqueezePlanCompute.Request(part=self.part, first_angle=self.link.p["squeeze_first_angle"])
        response: Any = Outcome("NO_ANSWER", 0, "no call made")
        for _ in range(PLAN_CALLS):
            response = self.link.call("squeeze_planner", self.planner, request)
            if not (isinstance(response, Outcome) and response.event == "NO_ANSWER"):
                break
        if isinstance(response, Outcome):
            return response
        self.plan_answer = response
        self.plan_angles = [float(a) for a in response.angles]
        angles = ", ".join(f"{a:.6f}" for a in self.plan_angles)
        self.node.get_logger().info(
            f"squeeze plan from {self.planner.srv_name}: {len(self.plan_angles)} squeezes at "
            f"[{angles}] rad, final orientation {response.final_orientation:.6f} rad modulo "
            f"{response.symmetry_period:.6f}, margin {response.margin:.6f} rad"
        )
        return None

    def place(self) -> Outcome | None:
        """Put a new part between the gripper's open jaws; an Outcome if that failed."""
        p = self.link.p
        request = SqueezePlacePart.Request(orientation=p["squeeze_orientation"], random=p["squeeze_random"])
        response = self.link.call("squeeze", self.place_part, request)
        if isinstance(response, Outcome):
            return response
        self.node.get_logger().info(
            f"cycle {self.machine.cycle}: a part arrives in the squeeze gripper at "
            f"{response.orientation:.6f} rad"
        )
        return None

    def wait_jaws_open(self) -> Outcome | None:
        """Wait (``squeeze_timeout`` of node clock) for a gripper ~/state after now saying IDLE."""
        future: Future = Future()
        self.jaws_open = (self.node.get_clock().now().nanoseconds, future)
        if self.link.wait(future, self.link.p["squeeze_timeout"]):
            return None
        return Outcome(
            "NO_ANSWER",
            0,
            f"{self.link.devices['squeeze']}/state did not say IDLE (the jaws open) within "
            f"{self.link.p['squeeze_timeout']:g} s of the reset",
        )

    def _on_state(self, msg: SqueezeState) -> None:
        pending = self.jaws_open
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if pending is not None and msg.phase == "IDLE" and stamp > pending[0] and not pending[1].done():
            pending[1].set_result(True)
