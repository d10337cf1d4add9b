"""ROS 2 node: the simulated throwing arm with a one-bit proximity sensor, a managed device.

An adapter (docs/devices.md): the model is ``feeder_sim.throwing`` (the arm, its faults, the throw cycle
of ``cycle``, the feed goal of ``feeding``), the parameters ``throwing.parameters``, the counters
``throwing.counters``; the device kit (``feeder_device``) owns the lifecycle, the tick, the streams and
the goal runner. Streams and services are private names (``~/sensor``, ``~/command``...), stamped with
the node clock (``use_sim_time`` honoured). The simulated time advances at each tick by the elapsed
node-clock time, at most MAX_TICK_PERIODS sensor periods per tick: a node that cannot keep up lags
visibly in its status, never silently.

``~/feed_part`` (feeder_msgs/FeedPart) throws until the one-bit sensor reads true with the part at rest,
decided by ``feeder_sim.throwing.feeding`` from what the device itself delivers; its throws go through
the same queue, period and motion as ``~/command throw``. While a goal executes, ``~/command throw`` and
``start`` and ``~/place_part`` are refused, ``~/command stop`` ends the goal after the throw in flight
(CANCELED), and ``~/stop`` lands the throw at once and ends the goal (CANCELED, aborted).
"""

from __future__ import annotations

import math
from typing import Sequence

from builtin_interfaces.msg import Time as StampMsg
from geometry_msgs.msg import PoseStamped
from rclpy.action.server import ServerGoalHandle
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from feeder_device.declarations import ActiveFault, DeviceError, FaultSpec
from feeder_device.device import DeviceState, ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import FeedPart
from feeder_msgs.msg import DeviceStatus, ThrowEvent
from feeder_msgs.srv import ArmCommand, ArmPlacePart
from feeder_planner.node_kit import EVENT_DEPTH, STREAM_DEPTH, run_node, service_guard, yaw_quaternion
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import DeviceViz, Drawing, viz_parameters
from feeder_sim.throwing import (
    FAULT_INFO,
    MAX_TICK_PERIODS,
    ArmFaults,
    ThrowingArm,
    ThrowOutcome,
    parse_command,
)
from feeder_sim.throwing.counters import COUNTERS
from feeder_sim.throwing.cycle import Pose, Shown, ThrowCycle, ns
from feeder_sim.throwing.drawing import ArmDrawing
from feeder_sim.throwing.feeding import FeedGoal, check_feed_goal
from feeder_sim.throwing.parameters import BASE_FRAME, ArmParameters, configure_arm

__all__ = ["PARAMETERS", "FAULTS", "ThrowingArmNode", "main"]

# The arm frame has gravity along -y: by default the cell (z up) sees it rolled a quarter turn.
DISPLAY = viz_parameters(cell_pose=(0.0, 0.0, 0.0, math.pi / 2, 0.0, 0.0))
PARAMETERS = device_parameter_specs(ArmParameters, DISPLAY)

# The kit's specs of the model's faults (feeder_sim.throwing.faults), with their status codes.
_CODES = {"motor_fault": DeviceStatus.FAULT_MOTOR, "part_lost": DeviceStatus.FAULT_PART_LOST}
FAULTS: dict[str, FaultSpec] = {
    name: FaultSpec(
        name,
        info.description,
        info.value_meaning,
        info.stops,
        _CODES.get(name, 0),
        shows_state=name in ("sensor_stuck", "release_speed_error"),  # the stuck bit; a fixed e
    )
    for name, info in FAULT_INFO.items()
}


class ThrowingArmNode(ManagedDevice[ArmParameters]):
    """Throw-catch cycles at a period; publishes joint state, part pose, throw events and the sensor bit."""

    FAULTS = FAULTS
    COUNTERS = COUNTERS

    def __init__(self) -> None:
        super().__init__("throwing_arm", ArmParameters, DISPLAY)
        self.arm: ThrowingArm | None = None
        self.cycle: ThrowCycle | None = None
        self._forget_run()
        guard = service_guard(self)
        # Served from the start; refused unless the device is ready (require_ready names the state).
        serve(self, ArmCommand, "~/command", guard(self._on_command))
        serve(self, ArmPlacePart, "~/place_part", guard(self._on_place_part))
        serve_goal(self, FeedPart, "~/feed_part", self._validate_feed_part, self._start_feed_part)
        self.viz = DeviceViz(self, self.drawing)

    def _forget_run(self) -> None:
        """Forget the simulated time and what was last shown (the kit resets the counters)."""
        # The model's time in integer ns (no rounding drift at epoch magnitudes): the node clock's at the
        # first activation, then advanced per tick by the elapsed node-clock time, capped.
        self.simulated = 0
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
        """Build the arm, its faults and the throw cycle from the parameters, then the streams."""
        arm = configure_arm(p)
        self.arm, self.cycle = arm, ThrowCycle(arm, ArmFaults(arm))
        self._forget_run()
        self.cycle.running = bool(p.autostart)
        self.frame_id = p.frame_id or self.frame(BASE_FRAME)
        self.pub_joint = self.stream(JointState, "~/joint_states", STREAM_DEPTH)
        self.pub_pose = self.stream(PoseStamped, "~/part_pose", STREAM_DEPTH)
        self.pub_event = self.stream(ThrowEvent, "~/throw_events", EVENT_DEPTH)
        self.pub_sensor = self.stream(Bool, "~/sensor", EVENT_DEPTH)
        self.expect_rate(p.sensor_rate)

    def activate_device(self) -> None:
        """Resume the simulated time (first activation: start it at the node clock's)."""
        if not self.simulated:
            self.simulated = self.get_clock().now().nanoseconds

    def cleanup_device(self) -> None:
        """Release the model."""
        self.arm = self.cycle = None
        self._forget_run()

    # --- status, parameters, stop, reset, faults --------------------------------------------------
    def busy(self) -> bool:
        """Throwing: running every period, throws queued, a throw being shown, or a feed goal executing."""
        return super().busy() or (self.cycle is not None and self.cycle.busy)

    def apply_parameter(self, name: str, p: ArmParameters) -> None:
        """Apply a runtime parameter to the running arm (the read-only ones never get here)."""
        if name == "release_speed":
            self._cycle().arm.set_release_speed(float(p.release_speed))
        elif name == "dynamic_step":
            self._cycle().arm.dynamic_step = float(p.dynamic_step)
        # period, motion_fraction, sensor_radius and sensing_height are read from self.p at each tick,
        # which the kit updates once this returns.

    def stop_device(self) -> None:
        """Cancel the queue and the running cycle; a throw being shown lands at once (it was thrown).

        A feed goal ends at once: CANCELED (aborted, not asked by its client), its last throw reported.
        """
        cycle = self._cycle()
        cycle.cancel_commands()
        if cycle.motion is not None:
            outcome, cycle.motion = cycle.motion.outcome, None
            self._publish_event(self.get_clock().now().nanoseconds, outcome)
        if self.feed is not None:
            self.feed.end_now("CANCELED", f"stopped by ~/stop after {self.feed.throws} throw(s)")
            self.wake_goals()

    def reset_device(self) -> None:
        """Back to IDLE, except that a part that is off the arm (or faulted) still needs ~/place_part."""
        self._cycle().cancel_commands()
        self._require_part_again()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Check the magnitudes and put the fault into effect on the model (a stopping one halts throws)."""
        cycle = self._cycle()
        cycle.faults.inject(fault.spec.name, fault.value, fault.state, fault.indices, fault.seed)
        if fault.spec.stops_device:
            cycle.cancel_commands()
            self.count.add("faults")
        if fault.spec.name == "part_lost":
            cycle.motion = None  # a part in the air falls off with the rest: no landing to show

    def clear_fault(self, name: str) -> None:
        """Take the fault out of effect; a part lost stays lost (FAULT_PART_LOST) until ~/place_part."""
        self._cycle().faults.clear(name)
        self._require_part_again()

    def _require_part_again(self) -> None:
        """Hold FAULT_PART_LOST while the model cannot throw until the part is placed again."""
        if self.arm is not None and self.arm.faulted and self.model_fault is None:
            self.model_fault = (
                DeviceStatus.FAULT_PART_LOST,
                f"{self.arm.faulted} (~/place_part puts it back)",
            )

    def _cycle(self) -> ThrowCycle:
        if self.cycle is None:
            raise DeviceError(f"device is {self.state().name}: no arm model (configure it first)")
        return self.cycle

    # --- services -----------------------------------------------------------------------------------
    def _on_command(self, request: ArmCommand.Request, response: ArmCommand.Response) -> ArmCommand.Response:
        """Queue throws, or start or stop throwing every period (refused unless the device is ready)."""
        command = parse_command(request.command)
        self.require_ready(f"command {command}")
        cycle = self._cycle()
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

    def _on_place_part(
        self, request: ArmPlacePart.Request, response: ArmPlacePart.Response
    ) -> ArmPlacePart.Response:
        """Put the part at rest at (edge, R), ending any throw being shown; this ends FAULT_PART_LOST."""
        self._require_place_ready()
        if self.feed is not None:
            raise DeviceError("place_part refused: a ~/feed_part goal is executing (cancel it first)")
        self._cycle().place(request.edge, request.radius, self.p.arm_length)
        self.faults.pop("part_lost", None)
        self.model_fault = None
        self.publish_status()
        return response

    def _require_place_ready(self) -> None:
        """Accept ~/place_part when ready, or in FAULT when every cause is a part lost (placing ends it)."""
        fault = self.stopping_fault()
        others = [f for f in self.faults.values() if f.spec.stops_device and f.spec.name != "part_lost"]
        lost_only = fault is not None and fault[0] == DeviceStatus.FAULT_PART_LOST and not others
        if not (lost_only and self.active and not self.stopped):
            self.require_ready("place_part")

    # --- the main stream ------------------------------------------------------------------------------
    def tick(self, now_ns: int) -> float:
        """Advance the simulated time, the shown throw or the next one; publish sensor, joint, part pose."""
        cycle = self._cycle()
        self.simulated += min(self.elapsed_ns(now_ns), ns(MAX_TICK_PERIODS / self.p.sensor_rate))
        t = self.simulated
        in_flight = cycle.motion is not None
        shown = cycle.show(t, ns(self.p.period * self.p.motion_fraction))
        if shown.landed is not None:
            self._publish_event(now_ns, shown.landed)
        elif not in_flight:
            feed_wants = self.feed is not None and self.feed.wants_throw(now_ns)
            ready = self.state() in (DeviceState.IDLE, DeviceState.RUNNING)
            if cycle.throw_due(t, ns(self.p.period), feed_wants, ready):
                self._throw(now_ns, t)
        self._publish_sensor(None if cycle.motion is None else shown.pose)
        self._publish_joint_and_pose(now_ns, shown)
        return self.simulated * 1e-9

    def _throw(self, now_ns: int, t: int) -> None:
        """Throw once; show it over the motion window, or report a fault at once (FAULT_PART_LOST)."""
        outcome = self._cycle().throw(t)
        self.count.add("throws")
        if self.feed is not None:
            self.feed.throw_started()
        if outcome.kind == "fault":
            self.count.add("faults")
            self._publish_event(now_ns, outcome)
            self.raise_model_fault(
                DeviceStatus.FAULT_PART_LOST,
                f"throw {self.count['throws']}: {outcome.fault} (~/place_part puts it back)",
            )
        else:
            self.publish_status()

    def _publish_sensor(self, pose: Pose | None) -> None:
        """Publish the sensor bit (at rest, or for the pose shown in flight) as the faults deliver it."""
        cycle = self._cycle()
        reading = cycle.arm.sensor(self.p.sensor_radius, self.p.sensing_height, pose)
        delivered = cycle.faults.sensor(reading)
        if delivered is not None:
            self.last_bit = delivered
            self.pub_sensor.publish(Bool(data=delivered))
        if pose is None and self.feed is not None:
            self.feed.sample(delivered)  # the bit as published decides, faults and all

    def _publish_joint_and_pose(self, now_ns: int, shown: Shown) -> None:
        """Publish the arm joint state, and the part pose in the arm frame while the part is on the arm."""
        stamp = _stamp(now_ns)
        joint = JointState(
            name=["arm_joint"], position=[shown.joint], velocity=[shown.velocity], effort=[0.0]
        )
        joint.header.stamp = stamp
        self.shown = (shown.pose, shown.joint)
        self.pub_joint.publish(joint)
        if not self._cycle().arm.on_arm:
            return  # nothing on the arm to locate
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.frame_id
        msg.pose.position.x, msg.pose.position.y = shown.pose[0], shown.pose[1]
        msg.pose.orientation = yaw_quaternion(shown.pose[2])
        self.pub_pose.publish(msg)

    def _publish_event(self, now_ns: int, outcome: ThrowOutcome) -> None:
        """Publish the throw event: states before and after, kind, fault, the (true) sensor at rest."""
        arm = self._cycle().arm
        ev = ThrowEvent()
        ev.header.stamp, ev.header.frame_id = _stamp(now_ns), self.frame_id
        ev.index = self.count["throws"]
        ev.edge_before, ev.radius_before = outcome.edge_before, outcome.radius_before
        ev.edge_after, ev.radius_after = outcome.edge_after, outcome.radius_after
        ev.kind, ev.turns, ev.rotation = outcome.kind, outcome.turns, outcome.rotation
        ev.fault, ev.fault_reason = outcome.kind == "fault", outcome.fault
        ev.sensor_at_rest = bool(arm.sensor(self.p.sensor_radius, self.p.sensing_height))
        ev.fidelity = self.p.fidelity
        # The paper model's assumptions this throw broke (issue 14); off_arm made it a part lost above.
        ev.lift_off, ev.slip = "lift_off" in outcome.flags, "slip" in outcome.flags
        ev.off_arm, ev.toe_stub = "off_arm" in outcome.flags, "toe_stub" in outcome.flags
        if ev.sensor_at_rest and not ev.fault:
            self.count.add("parts_presented")
        self.pub_event.publish(ev)
        if self.feed is not None:
            self.feed.landed(now_ns, *self._ground_truth(), ev)
        self.publish_status()

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
        cycle = self._cycle()
        if cycle.busy:
            raise DeviceError(
                f"~/feed_part goal refused: ~/command keeps the arm busy ({cycle.doing()}); "
                "~/command stop, or wait for IDLE"
            )

    def _start_feed_part(self, handle: ServerGoalHandle) -> FeedPartGoal:
        """Start an accepted goal's machine at the node clock's now."""
        request = check_feed_goal(int(handle.request.max_throws), float(handle.request.timeout))
        feed: FeedGoal[ThrowEvent] = FeedGoal(
            request, self.get_clock().now().nanoseconds, self._rest_window_ns(), *self._ground_truth()
        )
        self.count.add("feed_goals")
        self.get_logger().info(
            f"~/feed_part: goal accepted (max_throws {request.max_throws}, timeout {request.timeout:g} s)"
        )
        return FeedPartGoal(self, feed, handle)

    def _rest_window_ns(self) -> int:
        """Return the longest wait (ns) for a delivered sensor sample once the part is at rest.

        The rest time between throws less one sample: an unread bit then asks for the next throw in
        time for it to start a period after the last one, as if the bit had been read.
        """
        rest = self.p.period * (1.0 - self.p.motion_fraction) - 1.0 / self.p.sensor_rate
        return ns(max(rest, 0.0))

    def _ground_truth(self) -> tuple[int, float]:
        """Return (edge, R) of the part at rest, or (-1, NaN) when it is not on the arm (for logging)."""
        arm = self.arm
        if arm is None or not arm.on_arm:
            return -1, math.nan
        return arm.edge, arm.radius


class FeedPartGoal:
    """The runner's view of a ``FeedGoal``: its feedback and result as FeedPart messages."""

    def __init__(self, node: ThrowingArmNode, feed: FeedGoal[ThrowEvent], handle: ServerGoalHandle) -> None:
        self.node, self.feed, self.handle = node, feed, handle

    @property
    def done(self) -> bool:
        """Whether the feed goal has ended."""
        return self.feed.done

    def advance(self, now_ns: int) -> None:
        """Take in the tick that is over: judge the bit, end, or ask for a throw."""
        cycle = self.node.cycle
        self.feed.tick(now_ns, self.node.stopping_fault(), cycle is not None and cycle.motion is not None)

    def cancel(self, reason: str) -> None:
        """End after the throw in flight, at once at rest (unless a ~/command stop already asked it to)."""
        if not self.feed.cancel_reason:
            self.feed.cancel(reason)
            self.advance(self.node.get_clock().now().nanoseconds)

    def halt(self) -> None:
        """Forget the throws the goal asked for (a throw in flight still lands)."""
        if self.node.cycle is not None:
            self.node.cycle.cancel_commands()

    def interrupt(self, reason: str) -> None:
        """End now: the device left active, so no throw can land."""
        state = self.node.state().name
        self.feed.end_now(
            "FAULT",
            f"device {state} (deactivated) during the goal: the physics is frozen "
            "and no throw can land; activate it and send a new goal",
            DeviceStatus.FAULT_NONE,
            f"device {state}",
        )

    def feedback(self) -> Sequence[FeedPart.Feedback]:
        """One feedback per throw the goal has judged, in order."""
        reports, self.feed.reports = self.feed.reports, []
        return [
            FeedPart.Feedback(
                throws=r.throws,
                sensor_at_rest=r.sensor_at_rest,
                edge=r.edge,
                radius=r.radius,
                event=r.event if r.event is not None else ThrowEvent(),
            )
            for r in reports
        ]

    def result(self) -> tuple[str, FeedPart.Result]:
        """Return the terminal state and result: the outcome's code and name, the arm's state now."""
        outcome = self.feed.outcome
        assert outcome is not None  # the runner asks only once the goal ended
        # The arm's state now is the ground truth after the goal's last throw, and says (-1, NaN)
        # when the part has left the arm, which the goal itself never saw land.
        edge, radius = self.node._ground_truth()
        result = FeedPart.Result(
            outcome=outcome.code,
            outcome_name=outcome.name,
            message=outcome.message,
            throws=outcome.throws,
            sensor_at_rest=outcome.sensor_at_rest,
            edge=edge,
            radius=radius,
            fault_code=outcome.fault_code,
            fault_text=outcome.fault_text,
        )
        log = self.node.get_logger()
        if outcome.name == "PRESENTED":
            self.node.count.add("feeds_presented")
            log.info(f"~/feed_part: {outcome.name}: {outcome.message}")
            return "succeed", result
        log.warning(f"~/feed_part: {outcome.name}: {outcome.message}")
        canceled = outcome.name == "CANCELED" and self.handle.is_cancel_requested
        return ("canceled" if canceled else "abort"), result


def _stamp(nanoseconds: int) -> StampMsg:
    """Return a node-clock time (integer ns) as a message stamp."""
    return Time(nanoseconds=nanoseconds).to_msg()


def main(args: list[str] | None = None) -> None:
    """Run the throwing_arm node."""
    run_node(ThrowingArmNode, "throwing_arm", args)


if __name__ == "__main__":
    main()
