"""ROS 2 node: the simulated throwing arm with a one-bit proximity sensor, a managed device.

An adapter (docs/devices.md): the station ``feeder_sim.throwing.station`` holds what a tick and a feed
goal do to the model (the arm, its faults, the throw ``cycle``, the feed goal of ``feeding``), the same
station the ROS-free cell loop ticks; the part ``loading``, parameters, counters and fault specs are
beside it, the messages in ``node_kit.msg_throwing``; the device kit owns lifecycle, tick, streams and
goal runner. The node publishes what the station reports. Each tick advances the simulated time by the
elapsed node-clock time, at most MAX_TICK_PERIODS sensor periods: a node that cannot keep up lags
visibly in its status, never silently. While ``~/feed_part`` executes, ``~/command
throw`` and ``start``, ``~/place_part`` and ``~/load_part`` are refused, ``~/command stop`` ends it after
the throw in flight, and ``~/stop`` at once (docs/throwing.md).
"""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseStamped
from rclpy.action.server import ServerGoalHandle
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from feeder_device.declarations import ActiveFault, DeviceError
from feeder_device.device import DeviceState, ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import FeedPart
from feeder_msgs.msg import DeviceStatus, ThrowEvent
from feeder_msgs.msg import Part as PartMsg
from feeder_msgs.srv import ArmCommand, ArmLoadPart, ArmPlacePart
from feeder_planner.node_kit import EVENT_DEPTH, LATCHED, STREAM_DEPTH, run_node, service_guard
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import DeviceViz, Drawing, viz_parameters
from feeder_sim.node_kit.arm_parts import ArmPartServices
from feeder_sim.node_kit.msg_throwing import (
    FeedPartGoal,
    held_part_msg,
    joint_state_msg,
    part_pose_msg,
    throw_event_msg,
)
from feeder_sim.throwing import ThrowingArm, ThrowOutcome, parse_command
from feeder_sim.throwing.counters import COUNTERS
from feeder_sim.throwing.cycle import Pose, Shown, ThrowCycle
from feeder_sim.throwing.drawing import ArmDrawing
from feeder_sim.throwing.fault_specs import fault_specs
from feeder_sim.throwing.feeding import FeedGoal, check_feed_goal
from feeder_sim.throwing.loading import HeldPart, configured_part
from feeder_sim.throwing.parameters import BASE_FRAME, ArmParameters
from feeder_sim.throwing.station import ArmStation

__all__ = ["PARAMETERS", "FAULTS", "ThrowingArmNode", "main"]

# The arm frame has gravity along -y: by default the cell (z up) sees it rolled a quarter turn.
DISPLAY = viz_parameters(cell_pose=(0.0, 0.0, 0.0, math.pi / 2, 0.0, 0.0))
PARAMETERS = device_parameter_specs(ArmParameters, DISPLAY)

# The kit's specs of the model's faults (throwing/fault_specs.py) with their DeviceStatus codes.
FAULTS = fault_specs({"motor_fault": DeviceStatus.FAULT_MOTOR, "part_lost": DeviceStatus.FAULT_PART_LOST})


class ThrowingArmNode(ManagedDevice[ArmParameters]):
    """Throw-catch cycles at a period; publishes joint state, part pose, throw events and the sensor bit."""

    FAULTS = FAULTS
    COUNTERS = COUNTERS

    def __init__(self) -> None:
        super().__init__("throwing_arm", ArmParameters, DISPLAY)
        self.station: ArmStation[ThrowEvent] | None = None
        self.arm: ThrowingArm | None = None
        self.cycle: ThrowCycle | None = None
        self.held: HeldPart | None = None  # the part the arm holds: name, document, source
        self._forget_run()
        guard = service_guard(self)
        # Served from the start; refused unless the device is ready (require_ready names the state).
        serve(self, ArmCommand, "~/command", guard(self._on_command))
        parts = ArmPartServices(self)
        serve(self, ArmPlacePart, "~/place_part", guard(parts.on_place_part))
        serve(self, ArmLoadPart, "~/load_part", guard(parts.on_load_part))
        serve_goal(self, FeedPart, "~/feed_part", self._validate_feed_part, self._start_feed_part)
        self.viz = DeviceViz(self, self.drawing)

    def _forget_run(self) -> None:
        """Forget the simulated time and what was last shown (the kit resets the counters)."""
        self.shown: tuple[Pose, float] | None = None  # the pose and joint angle last published, for ~/markers
        self.last_bit: bool | None = None  # the sensor bit last delivered
        self.arm_drawing = ArmDrawing()

    @property
    def feed(self) -> FeedGoal[ThrowEvent] | None:
        """The ~/feed_part goal executing, if any (the arm has one action: at most one goal)."""
        goal = self.goals[0].goal if self.goals else None
        return goal.feed if isinstance(goal, FeedPartGoal) else None

    # --- lifecycle hooks ---------------------------------------------------------------------------
    def configure_device(self, p: ArmParameters) -> None:
        """Build the station (the arm, its faults and the throw cycle), then the streams."""
        station: ArmStation[ThrowEvent] = ArmStation(p, self)
        held = configured_part(p, station.arm.part)
        self.station, self.arm, self.cycle, self.held = station, station.arm, station.cycle, held
        self._forget_run()
        self.frame_id = p.frame_id or self.frame(BASE_FRAME)
        self.pub_joint = self.stream(JointState, "~/joint_states", STREAM_DEPTH)
        self.pub_pose = self.stream(PoseStamped, "~/part_pose", STREAM_DEPTH)
        self.pub_event = self.stream(ThrowEvent, "~/throw_events", EVENT_DEPTH)
        self.pub_sensor = self.stream(Bool, "~/sensor", EVENT_DEPTH)
        self.pub_part = self.stream(PartMsg, "~/part", LATCHED, lifecycle=False)
        self.publish_part()
        self.expect_rate(p.sensor_rate)

    def activate_device(self) -> None:
        """Resume the simulated time (first activation: start it at the node clock's)."""
        station = self.model_station()
        if not station.simulated:
            station.simulated = self.get_clock().now().nanoseconds

    def cleanup_device(self) -> None:
        """Release the model."""
        self.station, self.arm, self.cycle = None, None, None
        self.held = None
        self._forget_run()

    # --- status, parameters, stop, reset, faults --------------------------------------------------
    def busy(self) -> bool:
        """Throwing: running every period, throws queued, a throw being shown, or a feed goal executing."""
        return super().busy() or (self.cycle is not None and self.cycle.busy)

    def apply_parameter(self, name: str, p: ArmParameters) -> None:
        """Apply a runtime parameter to the running arm (the read-only ones never get here)."""
        if name == "release_speed":
            self.model_cycle().arm.set_release_speed(float(p.release_speed))
        elif name == "dynamic_step":
            self.model_cycle().arm.dynamic_step = float(p.dynamic_step)
        # period, motion_fraction, sensor_radius and sensing_height are read from the station's p at each
        # tick; set once the change was accepted (a refused one leaves the station as the node's p).
        if self.station is not None:
            self.station.p = p

    def stop_device(self) -> None:
        """Cancel the queue and the running cycle; a throw being shown lands at once (it was thrown).

        A feed goal ends at once: CANCELED (aborted, not asked by its client), its last throw reported.
        """
        self.model_station().stop(self.get_clock().now().nanoseconds, self.feed)
        if self.feed is not None:
            self.feed.end_now("CANCELED", f"stopped by ~/stop after {self.feed.throws} throw(s)")
            self.wake_goals()

    def reset_device(self) -> None:
        """Back to IDLE, except that a part that is off the arm (or faulted) still needs ~/place_part."""
        self.model_cycle().cancel_commands()
        self._require_part_again()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Check the magnitudes and put the fault into effect on the model (a stopping one halts throws)."""
        self.model_station().apply_fault(fault)
        if fault.spec.stops_device:
            self.count.add("faults")

    def clear_fault(self, name: str) -> None:
        """Take the fault out of effect; a part lost stays lost (FAULT_PART_LOST) until ~/place_part."""
        self.model_cycle().faults.clear(name)
        self._require_part_again()

    def _require_part_again(self) -> None:
        """Hold FAULT_PART_LOST while the model cannot throw until the part is placed again."""
        lost = self.station.lost_part_text() if self.station is not None else None
        if lost is not None and self.model_fault is None:
            self.model_fault = (DeviceStatus.FAULT_PART_LOST, lost)

    def model_station(self) -> ArmStation[ThrowEvent]:
        """Return the station (DeviceError naming the state when unconfigured)."""
        if self.station is None:
            raise DeviceError(f"device is {self.state().name}: no arm model (configure it first)")
        return self.station

    def model_cycle(self) -> ThrowCycle:
        """Return the throw cycle (DeviceError naming the state when unconfigured)."""
        return self.model_station().cycle

    # --- services -----------------------------------------------------------------------------------
    def _on_command(self, request: ArmCommand.Request, response: ArmCommand.Response) -> ArmCommand.Response:
        """Queue throws, or start or stop throwing every period (refused unless the device is ready)."""
        command = parse_command(request.command)
        self.require_ready(f"command {command}")
        cycle = self.model_cycle()
        if self.feed is not None:
            # The goal owns the queue: extra throws would be neither its own nor a command's.
            if command != "stop":
                raise DeviceError(
                    f"command {command} refused: a ~/feed_part goal is executing "
                    "(cancel it, or ~/command stop, first)"
                )
            self.feed.cancel("stopped by ~/command stop")
            self.goals[0].advance_guarded(self.get_clock().now().nanoseconds)
            self.wake_goals()
        cycle.command(command, request.count)
        response.pending = cycle.pending
        self.publish_status()
        return response

    def publish_part(self) -> None:
        """Publish the part the arm holds (latched): its name, its outline in its file's order and unit."""
        if self.held is not None:
            self.pub_part.publish(held_part_msg(self.held))

    # --- the main stream: the station ticks, the node publishes what it reports ---------------------
    def tick(self, now_ns: int) -> float:
        """Tick the station (land, or throw, read the sensor); publish sensor, joint and part pose."""
        station = self.model_station()
        ready = self.state() in (DeviceState.IDLE, DeviceState.RUNNING)
        ticked = station.tick(now_ns, self.elapsed_ns(now_ns), self.feed, ready)
        if ticked.delivered is not None:
            self.last_bit = ticked.delivered
            self.pub_sensor.publish(Bool(data=ticked.delivered))
        self._publish_joint_and_pose(now_ns, ticked.shown)
        return station.simulated * 1e-9

    # --- ArmEvents: what the station reports within a tick ----------------------------------------
    def landed(self, now_ns: int, outcome: ThrowOutcome) -> ThrowEvent:
        """Publish the landing's throw event; the feed goal reports it with the throw."""
        return self._publish_event(now_ns, outcome)

    def thrown(self, now_ns: int, outcome: ThrowOutcome) -> None:
        """Count the throw; one that did not fault changes the status (busy) at once."""
        self.count.add("throws")
        if outcome.kind != "fault":
            self.publish_status()

    def part_lost(self, now_ns: int, outcome: ThrowOutcome, text: str) -> None:
        """Report the throw that lost the part and hold FAULT_PART_LOST."""
        self.count.add("faults")
        self._publish_event(now_ns, outcome)
        self.raise_model_fault(DeviceStatus.FAULT_PART_LOST, text)

    def _publish_joint_and_pose(self, now_ns: int, shown: Shown) -> None:
        """Publish the arm joint state, and the part pose in the arm frame while the part is on the arm."""
        self.shown = (shown.pose, shown.joint)
        self.pub_joint.publish(joint_state_msg(now_ns, shown))
        if self.model_cycle().arm.on_arm:  # else nothing on the arm to locate
            self.pub_pose.publish(part_pose_msg(now_ns, self.frame_id, shown.pose))

    def _publish_event(self, now_ns: int, outcome: ThrowOutcome) -> ThrowEvent:
        """Publish the throw event: states before and after, kind, fault, the (true) sensor at rest."""
        sensor_at_rest = bool(self.model_station().reading())
        index = self.count["throws"]
        ev = throw_event_msg(now_ns, self.frame_id, index, outcome, sensor_at_rest, self.p.fidelity)
        if ev.sensor_at_rest and not ev.fault:
            self.count.add("parts_presented")
        self.pub_event.publish(ev)
        self.publish_status()
        return ev

    def drawing(self) -> Drawing | None:
        """Return what ~/markers shows: the arm at its joint angle, the part on it, the sensor by its bit."""
        if self.arm is None:
            return None
        sensor = self.p.sensor_radius, self.p.sensing_height, self.last_bit
        return Drawing(
            self.frame_id, self.frame_id, dynamic=self.arm_drawing.shapes(self.arm, self.shown, sensor)
        )

    # --- ~/feed_part ----------------------------------------------------------------------------------
    def _validate_feed_part(self, goal: FeedPart.Goal) -> None:
        """Refuse a bad goal naming the field, or a goal while ~/command keeps the arm busy."""
        check_feed_goal(int(goal.max_throws), float(goal.timeout))
        cycle = self.model_cycle()
        if cycle.busy:
            raise DeviceError(
                f"~/feed_part goal refused: ~/command keeps the arm busy ({cycle.doing()}); "
                "~/command stop, or wait for IDLE"
            )

    def _start_feed_part(self, handle: ServerGoalHandle) -> FeedPartGoal:
        """Start an accepted goal's machine at the node clock's now."""
        request = check_feed_goal(int(handle.request.max_throws), float(handle.request.timeout))
        feed = self.model_station().feed_goal(request, self.get_clock().now().nanoseconds)
        self.count.add("feed_goals")
        self.get_logger().info(
            f"~/feed_part: goal accepted (max_throws {request.max_throws}, timeout {request.timeout:g} s)"
        )
        return FeedPartGoal(self, feed, handle)

    def ground_truth(self) -> tuple[int, float]:
        """Return (edge, R) of the part at rest, or (-1, NaN) off the arm or unconfigured (for logging)."""
        return self.arm.ground_truth() if self.arm is not None else (-1, math.nan)


NODE = ThrowingArmNode  # what the cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the throwing_arm node."""
    run_node(ThrowingArmNode, "throwing_arm", args)


if __name__ == "__main__":
    main()
