"""ROS 2 node: a parallel-jaw gripper that orients a part by squeezing it (Goldberg 1993), a managed device.

An adapter (docs/devices.md): the station ``feeder_sim.squeeze.station`` holds what a tick and a plan
goal do to the gripper; the model is ``feeder_sim.squeeze`` (the gripper, its fidelities ideal and
dynamic, its faults, the plan goal of ``plan_goal``; parameters, counters and fault specs beside them),
the messages ``feeder_sim.node_kit.msg_squeeze``; the device kit (``feeder_device``) owns the lifecycle,
the tick, the streams and the goal runner. ``~/squeeze`` (one angle) and ``~/run_plan`` (a plan, e.g.
from ``feeder squeeze-plan`` or the squeeze_planner node) run on one goal machine, one goal at a time
across both. Each tick advances the gripper by the elapsed node-clock time, at most
MAX_ADVANCE_PER_TICK (a longer gap is counted in ``capped_ticks``). docs/squeeze.md.
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.action.server import ServerGoalHandle
from sensor_msgs.msg import JointState

from feeder_device.declarations import ActiveFault, DeviceError
from feeder_device.device import ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import RunPlan, Squeeze
from feeder_msgs.msg import SqueezeState
from feeder_msgs.srv import SqueezePlacePart
from feeder_planner.drawing import Shape, lift, loop_strip, part_shapes, rotation_z, triangulate_loops
from feeder_planner.node_kit import STREAM_DEPTH, run_node, service_guard
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import VIZ_PARAMETERS, DeviceViz, Drawing
from feeder_planner.parts import Part
from feeder_planner.squeeze import check_angle
from feeder_sim.node_kit.msg_squeeze import SqueezeActionGoal, joint_state_msg, part_pose_msg, state_msg
from feeder_sim.squeeze.counters import COUNTERS
from feeder_sim.squeeze.fault_specs import fault_specs
from feeder_sim.squeeze.faults import FAULT_INFO, check_fault_name
from feeder_sim.squeeze.gripper import SqueezeGripper
from feeder_sim.squeeze.parameters import BASE_FRAME, GripperParameters
from feeder_sim.squeeze.plan_goal import PlanGoal, check_plan_goal
from feeder_sim.squeeze.station import SqueezeStation

__all__ = ["FAULTS", "NODE", "PARAMETERS", "SqueezeGripperNode", "main"]

NODE_NAME = "squeeze_gripper"
PARAMETERS = device_parameter_specs(GripperParameters, VIZ_PARAMETERS)

# The kit's specs of the gripper's faults (squeeze/fault_specs.py) with the codes of its own message.
FAULTS = fault_specs(
    {
        "jaw_stall": SqueezeState.FAULT_JAW_STALL,
        "part_dropped": SqueezeState.FAULT_PART_DROPPED,
        "jaw_worn": SqueezeState.FAULT_JAW_WORN,
    }
)
# The model fault each stopping gripper fault raises when it acts.
ACTING_CODES: dict[str, int] = {
    "jaw_stall": SqueezeState.FAULT_JAW_STALL,
    "part_dropped": SqueezeState.FAULT_PART_DROPPED,
}


class SqueezeGripperNode(ManagedDevice[GripperParameters]):
    """Publishes ~/state, ~/joint_states, ~/part_pose; serves ~/place_part, ~/squeeze and ~/run_plan."""

    FAULTS = FAULTS
    COUNTERS = COUNTERS

    def __init__(self) -> None:
        super().__init__(NODE_NAME, GripperParameters, VIZ_PARAMETERS, rate=50.0)
        self._forget()
        serve(self, SqueezePlacePart, "~/place_part", service_guard(self)(self._on_place_part))
        serve_goal(self, Squeeze, "~/squeeze", self._validate_squeeze, self._start_squeeze)
        serve_goal(self, RunPlan, "~/run_plan", self._validate_run_plan, self._start_run_plan)
        self.viz = DeviceViz(self, self.drawing)

    def _forget(self) -> None:
        """Forget the station (the kit destroys the streams and resets the counters)."""
        self.station: SqueezeStation | None = None
        self.gripper: SqueezeGripper | None = None
        self.part: Part | None = None
        self.triangles: np.ndarray | None = None
        self.plan: PlanGoal | None = None
        self.frame_id = ""

    # --- configure / cleanup --------------------------------------------------------------------------
    def configure_device(self, p: GripperParameters) -> None:
        """Load the part and build the gripper; InputError names a bad parameter."""
        self._forget()
        self.station = SqueezeStation(p)
        self.gripper, self.part = self.station.gripper, self.station.part
        self.triangles = triangulate_loops(self.part.loops())
        self.frame_id = p.frame_id or self.frame(BASE_FRAME)
        self.expect_rate(p.publish_rate)
        self.state_pub = self.stream(SqueezeState, "~/state", STREAM_DEPTH)
        self.joint_pub = self.stream(JointState, "~/joint_states", STREAM_DEPTH)
        self.pose_pub = self.stream(PoseStamped, "~/part_pose", STREAM_DEPTH)
        if self.gripper.holding:
            self.count.add("parts_placed")
        self.get_logger().info(
            f"gripping {self.part.name}: {self.gripper.squeeze.steps_per_period()} stable orientations a "
            f"period of {self.gripper.squeeze.period:.4f} rad, fidelity {p.fidelity}"
        )

    def cleanup_device(self) -> None:
        """Release the model."""
        self._forget()

    def model(self) -> SqueezeGripper:
        """Return the gripper (the device is configured whenever this is asked)."""
        return self.model_station().gripper

    def model_station(self) -> SqueezeStation:
        """Return the station (the device is configured whenever this is asked)."""
        assert self.station is not None
        return self.station

    # --- runtime parameters, status, stop/reset, faults ---------------------------------------------
    def apply_parameter(self, name: str, p: GripperParameters) -> None:
        """Apply friction, jaw_speed, turn_speed or dynamic_step from the next squeeze."""
        gripper = self.gripper
        if gripper is None:
            return
        if name == "friction":
            gripper.friction = float(p.friction)
        elif name == "jaw_speed":
            gripper.jaw_speed = float(p.jaw_speed)
        elif name == "turn_speed":
            gripper.turn_speed = float(p.turn_speed)
        elif name == "dynamic_step":
            gripper.dynamic = type(gripper.dynamic)(step=float(p.dynamic_step))

    def busy(self) -> bool:
        """Whether a squeeze is in progress (the jaws moving) or a goal executes; never once faulted.

        A fault that acts during a goal is raised inside the tick, before the kit advances the goal (which
        then ends FAULT): the status published with the fault would otherwise say busy for that instant.
        """
        if self.model_fault is not None:
            return False
        return super().busy() or (self.gripper is not None and self.gripper.phase != "IDLE")

    def stop_device(self) -> None:
        """Halt where it is and open the jaws; a goal ends at once, CANCELED."""
        if self.gripper is not None:
            self.gripper.halt()
        if self.plan is not None and not self.plan.done:
            self.plan.end_now("CANCELED", "stopped by ~/stop", self.gripper)
            self.wake_goals()

    def reset_device(self) -> None:
        """Back to IDLE: jaws stopped by a stall open again; a dropped part still needs ~/place_part."""
        if self.gripper is not None:
            self.gripper.recover()
            self._require_part_again()

    def _require_part_again(self) -> None:
        """Hold FAULT_PART_DROPPED while the part that dropped is not placed again."""
        gripper = self.gripper
        if gripper is not None and gripper.dropped and self.model_fault is None:
            self.model_fault = (
                SqueezeState.FAULT_PART_DROPPED,
                "the part dropped from the jaws (~/place_part puts it back)",
            )

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the gripper model (checked there: InputError naming the value)."""
        gripper = self.model()
        self.model_station().apply_fault(fault)
        self.get_logger().warning(
            f"injected fault {fault.spec.name}: {gripper.faults.describe(fault.spec.name)}"
        )

    def clear_fault(self, name: str) -> None:
        """Take a fault out of the model; a stall that acted ends with it (the jaws open), a drop does not.

        A dropped part stays dropped (FAULT_PART_DROPPED) until ~/place_part puts one back.
        """
        if self.station is None:
            return
        stalled = self.model_fault is not None and self.model_fault[0] == SqueezeState.FAULT_JAW_STALL
        if self.station.clear_fault(name, stalled):
            self.model_fault = None

    def warning_fault(self) -> tuple[int, str] | None:
        """Return (code, text) of a coded fault in force that does not stop the gripper (jaw_worn)."""
        for name, fault in self.faults.items():
            if fault.spec.code and not FAULT_INFO[check_fault_name(name)].stops:
                detail = self.gripper.faults.describe(name) if self.gripper is not None else ""
                return fault.spec.code, f"injected fault {name}: {detail or fault.spec.description}"
        return None

    # --- ~/place_part --------------------------------------------------------------------------------
    def _on_place_part(
        self, request: SqueezePlacePart.Request, response: SqueezePlacePart.Response
    ) -> SqueezePlacePart.Response:
        """Put the part between the open jaws (or at a random orientation); this ends FAULT_PART_DROPPED."""
        fault = self.stopping_fault()
        dropped_only = fault is not None and fault[0] == SqueezeState.FAULT_PART_DROPPED
        if not (dropped_only and self.active and not self.stopped):
            self.require_ready("place_part")
        if self.goals:
            raise DeviceError("place_part refused: a goal is executing; cancel it first")
        orientation = None if request.random else check_angle(request.orientation, "orientation")
        gripper = self.model()
        if gripper.phase != "IDLE":
            raise DeviceError(f"place_part refused: the jaws are {gripper.phase}; wait for IDLE")
        response.orientation = gripper.place(orientation)
        if dropped_only:
            self.model_fault = None
        self.count.add("parts_placed")
        self.publish_status()
        return response

    # --- the actions ---------------------------------------------------------------------------------
    def _require_free(self, what: str) -> None:
        """Refuse a goal while the other action's goal executes or no part is between the jaws."""
        # The kit's runner holds the executing goals (a goal its guard aborted is gone from it too).
        if self.goals:
            raise DeviceError(f"{what} goal refused: a squeeze goal is executing; cancel it first")
        if not self.model().holding:
            raise DeviceError(f"{what} goal refused: no part between the jaws; ~/place_part first")

    def _validate_squeeze(self, goal: Squeeze.Goal) -> None:
        """Goal-time check of ~/squeeze: the angle and timeout, a part, no other goal."""
        check_plan_goal([check_angle(goal.angle, "angle")], goal.timeout)
        self._require_free("~/squeeze")

    def _validate_run_plan(self, goal: RunPlan.Goal) -> None:
        """Goal-time check of ~/run_plan: the angles and timeout, a part, no other goal."""
        check_plan_goal(list(goal.angles), goal.timeout)
        self._require_free("~/run_plan")

    def _start(self, handle: ServerGoalHandle, angles: list[float], action: type) -> SqueezeActionGoal:
        """Start an accepted goal's machine at the node clock's now."""
        request = check_plan_goal(angles, float(handle.request.timeout))
        self.plan = self.model_station().start(request, self.get_clock().now().nanoseconds)
        return SqueezeActionGoal(self, self.plan, handle, action)

    def _start_squeeze(self, handle: ServerGoalHandle) -> SqueezeActionGoal:
        self.count.add("squeeze_goals")
        return self._start(handle, [float(handle.request.angle)], Squeeze)

    def _start_run_plan(self, handle: ServerGoalHandle) -> SqueezeActionGoal:
        self.count.add("plan_goals")
        return self._start(handle, [float(a) for a in handle.request.angles], RunPlan)

    # --- time and the streams ------------------------------------------------------------------------
    def tick(self, now_ns: int) -> float:
        """Tick the station; publish state, joints and the part pose; a fault that acts stops the gripper."""
        station = self.model_station()
        gripper = station.gripper
        ticked = station.tick(self.elapsed_ns(now_ns))
        if ticked.capped:
            self.count.add("capped_ticks")
        if ticked.fault is not None:
            name, text = ticked.fault
            self.count.add("jaw_stalls" if name == "jaw_stall" else "parts_dropped")
            self.raise_model_fault(ACTING_CODES[name], text)
        if ticked.squeezes:
            self.count.add("squeezes", ticked.squeezes)
        self.state_pub.publish(state_msg(now_ns, self.frame_id, gripper))
        self.joint_pub.publish(joint_state_msg(now_ns, self.frame_id, gripper))
        self.pose_pub.publish(part_pose_msg(now_ns, self.frame_id, gripper))
        return gripper.time

    def drawing(self) -> Drawing | None:
        """Return what ~/markers shows: the two jaws at their width and angle, and the part (ground truth)."""
        gripper, part = self.gripper, self.part
        if gripper is None or part is None:
            return None
        turn = rotation_z(gripper.gripper_angle)
        size = gripper.open_width
        shapes: list[Shape] = []
        for side in (-1.0, 1.0):
            face = side * 0.5 * gripper.jaw_width
            pad = np.array(
                [
                    [face, -0.5 * size],
                    [face + side * 0.1 * size, -0.5 * size],
                    [face + side * 0.1 * size, 0.5 * size],
                    [face, 0.5 * size],
                ]
            )
            shapes.append(Shape("line_strip", loop_strip(pad @ turn.T), "jaws", "device", 0.01 * size))
        if gripper.holding:
            shapes += part_shapes(
                part, (0.0, 0.0, gripper.orientation), "part", "part", triangles=self.triangles
            )
        shapes.append(
            Shape(
                "text",
                lift(np.array([[0.0, 0.7 * size]])),
                "label",
                "text",
                0.05 * size,
                f"{gripper.phase} {gripper.jaw_width * 1e3:.2f} mm",
            )
        )
        return Drawing(self.frame_id, self.frame_id, dynamic=shapes)


NODE = SqueezeGripperNode  # what the cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the squeeze_gripper node until shutdown."""
    run_node(SqueezeGripperNode, NODE_NAME, args)


if __name__ == "__main__":
    main()
