"""ROS 2 node: the simulated throwing arm with a one-bit proximity sensor, a managed device.

Adapts ``feeder_sim.throwing`` (the arm model and its injected faults) to ROS: a lifecycle node (the
node kit's ManagedDevice) whose streams and services are private names (``~/sensor``, ``~/command``...),
stamped with the node clock (``use_sim_time`` honoured). The simulated time advances at each tick by the
elapsed node-clock time, at most MAX_TICK_PERIODS sensor periods per tick: a node that cannot keep up
lags visibly in its status, never silently.

``~/feed_part`` (feeder_msgs/FeedPart) throws until the one-bit sensor reads true with the part at rest,
decided by ``feeder_sim.throwing.feeding`` from what the device itself delivers; its throws go through
the same queue, period and motion as ``~/command throw``. While a goal executes, ``~/command throw`` and
``start`` and ``~/place_part`` are refused, ``~/command stop`` ends the goal after the throw in flight
(CANCELED), and ``~/stop`` lands the throw at once and ends the goal (CANCELED, aborted).
"""

from __future__ import annotations

import math
from typing import Any

from geometry_msgs.msg import PoseStamped
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from rclpy.time import Time
from rclpy.timer import Timer
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from feeder_msgs.action import FeedPart
from feeder_msgs.msg import DeviceStatus, ThrowEvent
from feeder_msgs.srv import ArmCommand, ArmPlacePart
from feeder_planner.drawing import triangulate_loops
from feeder_planner.errors import InputError
from feeder_planner.node_kit import (
    EVENT_DEPTH,
    STREAM_DEPTH,
    ParameterSpec,
    finite,
    in_range,
    integer,
    negative,
    non_empty_string,
    non_negative,
    one_of,
    positive,
    run_node,
    service_guard,
    yaw_quaternion,
)
from feeder_planner.node_kit.actions import serve_device_action
from feeder_planner.node_kit.device import ActiveFault, DeviceError, DeviceState, FaultSpec, ManagedDevice
from feeder_planner.node_kit.request_limits import MAX_QUEUED_THROWS
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import DeviceViz, Drawing, viz_parameters
from feeder_planner.parts import load_part
from feeder_planner.throwing import ArmPart, ThrowParams, arm_part, lowest_radius
from feeder_sim.throwing import (
    DEFAULT_STEP,
    FAULT_INFO,
    FIDELITIES,
    FIDELITY_ALIASES,
    MAX_TICK_PERIODS,
    ArmFaults,
    ThrowingArm,
    ThrowOutcome,
    parse_command,
)
from feeder_sim.throwing.drawing import arm_shapes, display_length, part_on_arm_shapes, sensor_shapes
from feeder_sim.throwing.feeding import FeedGoal, check_feed_goal

__all__ = ["PARAMETERS", "FAULTS", "ThrowingArmNode", "main"]

# A start-up R of 0 means this multiple of the edge's lowest throwable R: clear of the domain's edge,
# where the left contact vertex barely lifts.
DEFAULT_RADIUS_FACTOR = 1.5
# Display of a throw within its motion window: the flight path fills the first FLIGHT_SHOWN of the window
# (the part then rests), and the joint shows the release speed during the first RELEASE_SHOWN.
FLIGHT_SHOWN = 0.8
RELEASE_SHOWN = 0.05
BASE_FRAME = "arm_pivot"
# Steady-clock period (s) at which a goal notices a cancel while the node clock is held (no ticks).
CANCEL_POLL = 0.05
Pose = tuple[float, float, float]

PARAMETERS = (
    ParameterSpec(
        "part_file",
        "",
        "part file (YAML, contract section 2); required",
        non_empty_string("a part file"),
        read_only=True,
    ),
    ParameterSpec(
        "offset", -0.005, "h: height of the arm surface above the pivot (m)", finite, read_only=True
    ),
    ParameterSpec(
        "release_speed",
        math.radians(320),
        "W: release angular speed (rad/s, > 0); applied from the next throw when set at run time",
        positive,
    ),
    ParameterSpec("gravity", -9.66, "g: gravity along y (m/s^2, < 0)", negative, read_only=True),
    ParameterSpec("mu", 0.5, "friction coefficient between arm and part (> 0)", positive, read_only=True),
    ParameterSpec(
        "fidelity",
        "paper",
        "paper (the paper's model; analytic is accepted for it), contact (paper plus lift-off and "
        "Coulomb impacts) or dynamic (pymunk, restitution and friction)",
        one_of((*FIDELITIES, *FIDELITY_ALIASES)),
        read_only=True,
    ),
    ParameterSpec(
        "dynamic_step",
        DEFAULT_STEP,
        "pymunk step (s) of the dynamic fidelity; applied from the next throw when set at run time",
        positive,
    ),
    ParameterSpec(
        "period", 0.5, "time between throws (s, node clock); applied at once when set at run time", positive
    ),
    ParameterSpec(
        "motion_fraction",
        0.3,
        "fraction of the period spent showing the throw (the rest is at rest); applied from the next throw",
        in_range(0.0, 1.0, include_low=False, include_high=False),
    ),
    ParameterSpec(
        "sensor_radius", 0.2, "x of the proximity sensor on the arm (m); applied at once at run time", finite
    ),
    ParameterSpec(
        "sensing_height",
        0.001,
        "sensing height above the arm surface (m, >= 0); applied at once at run time",
        non_negative,
    ),
    ParameterSpec(
        "sensor_rate",
        100.0,
        "rate of the sensor, joint state and part pose topics (Hz of the node clock): the main stream",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "initial_edge",
        -1,
        "stable hull edge the part starts on (-1: the first stable edge)",
        integer,
        read_only=True,
    ),
    ParameterSpec(
        "initial_radius",
        0.0,
        f"R at start (m); 0: {DEFAULT_RADIUS_FACTOR:g} x the lowest throwable radius of the edge",
        non_negative,
        read_only=True,
    ),
    ParameterSpec(
        "arm_length",
        0.4,
        "length of the arm from the pivot (m); a part beyond it has left the arm",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "autostart",
        False,
        "throw every period once active (else wait for a start/throw command)",
        read_only=True,
    ),
    ParameterSpec(
        "frame_id",
        "",
        f"frame of the part pose and throw events (at the arm pivot, gravity along -y); "
        f"empty: {BASE_FRAME} under the node's namespace",
        read_only=True,
    ),
    # The arm frame has gravity along -y: by default the cell (z up) sees it rolled a quarter turn.
    *viz_parameters(cell_pose=(0.0, 0.0, 0.0, math.pi / 2, 0.0, 0.0)),
)

# The kit's specs of the model's faults (feeder_sim.throwing.faults), with their status codes.
_CODES = {"motor_fault": DeviceStatus.FAULT_MOTOR, "part_lost": DeviceStatus.FAULT_PART_LOST}
FAULTS = {
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


class ThrowingArmNode(ManagedDevice):
    """Throw-catch cycles at a period; publishes joint state, part pose, throw events and the sensor bit."""

    FAULTS = FAULTS

    def __init__(self) -> None:
        super().__init__("throwing_arm", PARAMETERS)
        self.arm: ThrowingArm | None = None
        self.model_faults: ArmFaults | None = None
        self._tick_timer: Timer | None = None
        self._streams: list[Any] = []
        self._reset_run()
        guard = service_guard(self)
        # Served from the start; refused unless the device is ready (require_ready names the state).
        serve(self, ArmCommand, "~/command", guard(self._command))
        serve(self, ArmPlacePart, "~/place_part", guard(self._place))
        serve_device_action(self, FeedPart, "~/feed_part", self._validate_feed, self._execute_feed)
        self.viz = DeviceViz(self, self.drawing)

    def _reset_run(self) -> None:
        """Forget the commands, the shown throw, the counters and the simulated time."""
        self.running, self.pending = False, 0
        # (start ns, outcome, W released at) while a throw is shown
        self.motion: tuple[int, ThrowOutcome, float] | None = None
        self.last_throw: int | None = None  # simulated ns of the last throw
        self.throws = self.fault_count = self.presented = 0
        self.feed: FeedGoal[ThrowEvent] | None = None  # the ~/feed_part goal executing
        self.feed_goals = self.feeds_presented = 0
        self._feed_waiter: Future | None = None
        # The model's time in integer ns (no rounding drift at epoch magnitudes): the node clock's at the
        # first activation, then advanced per tick by the elapsed node-clock time, capped.
        self.simulated = 0
        self.last_tick: Time | None = None
        self.shown: tuple[Pose, float] | None = None  # the pose and joint angle last published, for ~/markers
        self.last_bit: bool | None = None  # the sensor bit last delivered
        self.part_triangles: tuple[ArmPart | None, Any] = (None, None)

    # --- lifecycle hooks ---------------------------------------------------------------------------
    def configure_device(self, p: dict[str, Any]) -> None:
        """Load the part, check the start and build the arm, its faults and the lifecycle publishers."""
        try:
            part = arm_part(load_part(p["part_file"]))
        except InputError as error:
            raise InputError("parameter part_file", str(error)) from None
        params = _throw_params(p)
        edge = self._initial_edge(part, p["initial_edge"])
        radius = p["initial_radius"] or DEFAULT_RADIUS_FACTOR * lowest_radius(part, edge, params)
        try:
            arm = ThrowingArm(part, params, edge, radius, p["fidelity"], p["arm_length"], p["dynamic_step"])
        except InputError as error:
            raise InputError(f"parameter initial_{error.field}", error.problem) from None
        self.arm, self.model_faults = arm, ArmFaults(arm)
        self._reset_run()
        self.running = bool(p["autostart"])
        self.frame_id = p["frame_id"] or self.frame(BASE_FRAME)
        self.pub_joint = self._lifecycle_publisher(JointState, "~/joint_states", STREAM_DEPTH)
        self.pub_pose = self._lifecycle_publisher(PoseStamped, "~/part_pose", STREAM_DEPTH)
        self.pub_event = self._lifecycle_publisher(ThrowEvent, "~/throw_events", EVENT_DEPTH)
        self.pub_sensor = self._lifecycle_publisher(Bool, "~/sensor", EVENT_DEPTH)
        self.expect_rate(p["sensor_rate"])

    @staticmethod
    def _initial_edge(part: ArmPart, initial_edge: int) -> int:
        """Return the start edge (-1: the first stable edge), or raise InputError naming initial_edge."""
        edge = initial_edge if initial_edge >= 0 else part.stable_edges[0]
        if not (0 <= edge < part.n) or not part.stable[edge]:
            raise InputError(
                "parameter initial_edge", f"must be a stable edge {part.stable_edges}, got {edge}"
            )
        return edge

    def _lifecycle_publisher(self, msg_type: Any, topic: str, depth: int) -> Any:
        """Create a publisher the lifecycle enables on activate and disables on deactivate."""
        publisher = self.create_lifecycle_publisher(msg_type, topic, depth)
        self._streams.append(publisher)
        return publisher

    def activate_device(self) -> None:
        """Start the tick timer (main stream at sensor_rate on the node clock); simulated time resumes."""
        now = self.get_clock().now()
        if not self.simulated:
            self.simulated = now.nanoseconds  # first activation: the model's time starts at the clock's
        self.last_tick = now  # a paused span is not simulated: the physics was frozen
        self._tick_timer = self.create_timer(1.0 / self.p["sensor_rate"], self._tick)

    def deactivate_device(self) -> None:
        """Cancel the timer: the part (and a throw being shown) stays exactly where it is."""
        if self._tick_timer is not None:
            self.destroy_timer(self._tick_timer)
            self._tick_timer = None

    def cleanup_device(self) -> None:
        """Release the timer, the publishers and the model."""
        self.deactivate_device()
        for publisher in self._streams:
            self.destroy_lifecycle_publisher(publisher)
        self._streams.clear()
        self.arm = self.model_faults = None
        self._reset_run()

    # --- status -------------------------------------------------------------------------------------
    def busy(self) -> bool:
        """Throwing: running every period, throws queued, a throw being shown, or a feed goal executing."""
        return self.running or self.pending > 0 or self.motion is not None or self.feed is not None

    def counters(self) -> dict[str, int]:
        """Throws, faults entered, parts presented (true sensor at rest), feed goals run and presented."""
        return {
            "throws": self.throws,
            "faults": self.fault_count,
            "parts_presented": self.presented,
            "feed_goals": self.feed_goals,
            "feeds_presented": self.feeds_presented,
        }

    # --- parameters, stop, reset, faults --------------------------------------------------------------
    def apply_parameter(self, name: str, value: Any) -> None:
        """Apply a runtime parameter to the running arm (the read-only ones never get here)."""
        if name == "release_speed":
            self._model().set_release_speed(float(value))
        elif name == "dynamic_step":
            self._model().dynamic_step = float(value)
        # period, motion_fraction, sensor_radius and sensing_height are read from self.p at each tick,
        # which the kit updates once this returns.

    def stop_device(self) -> None:
        """Cancel the queue and the running cycle; a throw being shown lands at once (it was thrown).

        A feed goal ends at once: CANCELED (aborted, not asked by its client), its last throw reported.
        """
        self._cancel_commands()
        if self.motion is not None:
            _, outcome, _ = self.motion
            self.motion = None
            self._publish_event(self.get_clock().now(), outcome)
        if self.feed is not None:
            self.feed.end_now("CANCELED", f"stopped by ~/stop after {self.feed.throws} throw(s)")
            self._wake_feed()

    def reset_device(self) -> None:
        """Back to IDLE, except that a part that is off the arm (or faulted) still needs ~/place_part."""
        self._cancel_commands()
        self._require_part_again()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Check the magnitudes and put the fault into effect on the model (a stopping one halts throws)."""
        self._faults_model().inject(fault.spec.name, fault.value, fault.state, fault.indices, fault.seed)
        if fault.spec.stops_device:
            self._cancel_commands()
            self.fault_count += 1
        if fault.spec.name == "part_lost":
            self.motion = None  # a part in the air falls off with the rest: no landing to show

    def clear_fault(self, name: str) -> None:
        """Take the fault out of effect; a part lost stays lost (FAULT_PART_LOST) until ~/place_part."""
        self._faults_model().clear(name)
        self._require_part_again()

    def _require_part_again(self) -> None:
        """Hold FAULT_PART_LOST while the model cannot throw until the part is placed again."""
        if self.arm is not None and self.arm.faulted and self.model_fault is None:
            self.model_fault = (
                DeviceStatus.FAULT_PART_LOST,
                f"{self.arm.faulted} (~/place_part puts it back)",
            )

    def _cancel_commands(self) -> None:
        self.running, self.pending = False, 0

    def _model(self) -> ThrowingArm:
        if self.arm is None:
            raise DeviceError(f"device is {self.state().name}: no arm model (configure it first)")
        return self.arm

    def _faults_model(self) -> ArmFaults:
        if self.model_faults is None:
            raise DeviceError(f"device is {self.state().name}: no arm model (configure it first)")
        return self.model_faults

    # --- services -----------------------------------------------------------------------------------
    def _command(self, request: ArmCommand.Request, response: ArmCommand.Response) -> ArmCommand.Response:
        """Queue throws, or start or stop throwing every period (refused unless the device is ready)."""
        command = parse_command(request.command)
        self.require_ready(f"command {command}")
        if self.feed is not None:
            # The goal owns the queue: extra throws would be neither its own nor a command's.
            if command != "stop":
                raise DeviceError(
                    f"command {command} refused: a ~/feed_part goal is executing "
                    "(cancel it, or ~/command stop, first)"
                )
            self.feed.cancel("stopped by ~/command stop")
            self._feed_tick(self.get_clock().now())
            self._wake_feed()
        if command == "throw":
            if request.count < 1:
                raise InputError("count", f"must be >= 1 for 'throw', got {request.count}")
            # pending is a uint32 in the reply: a queue past the limit is refused, never wrapped
            if self.pending + request.count > MAX_QUEUED_THROWS:
                raise InputError(
                    "count",
                    f"{request.count} more throws on {self.pending} queued exceeds the queue limit of "
                    f"{MAX_QUEUED_THROWS}",
                )
            self.pending += request.count
        elif command == "start":
            self.running = True
        else:  # stop
            self._cancel_commands()
        response.pending = self.pending
        self.publish_status()
        return response

    def _place(self, request: ArmPlacePart.Request, response: ArmPlacePart.Response) -> ArmPlacePart.Response:
        """Put the part at rest at (edge, R), ending any throw being shown; this ends FAULT_PART_LOST."""
        self._require_place_ready()
        if self.feed is not None:
            raise DeviceError("place_part refused: a ~/feed_part goal is executing (cancel it first)")
        if not math.isfinite(request.radius):
            raise InputError("radius", f"must be finite, got {request.radius!r}")
        if abs(request.radius) > self.p["arm_length"]:
            raise InputError(
                "radius",
                f"must be on the arm (|R| <= arm_length {self.p['arm_length']:g} m), got {request.radius:g}",
            )
        self._model().place(request.edge, request.radius)
        self.motion = None
        if "part_lost" in self.faults:
            self._faults_model().clear("part_lost")
            del self.faults["part_lost"]
        self.model_fault = None
        self.publish_status()
        return response

    def _require_place_ready(self) -> None:
        """Accept ~/place_part when ready, or in FAULT when every cause is a part lost (placing ends it)."""
        fault = self.stopping_fault()
        others = [f for f in self.faults.values() if f.spec.stops_device and f.spec.name != "part_lost"]
        lost_only = (
            fault is not None
            and fault[0] == DeviceStatus.FAULT_PART_LOST
            and not others
            and self.active
            and not self.stopped
        )
        if not lost_only:
            self.require_ready("place_part")

    # --- the main stream ------------------------------------------------------------------------------
    def _tick(self) -> None:
        """Advance the simulated time, the shown throw or the next one; publish sensor, joint, part pose."""
        if self.arm is None:
            return
        now = self.get_clock().now()
        if not self.tick_due(now.nanoseconds):
            return
        self._advance_clock(now)
        t = self.simulated
        pose, velocity = self.arm.rest_pose(), 0.0
        if self.motion is not None:
            pose, velocity = self._advance_motion(now, t, pose, *self.motion)
        elif self._throw_due(t, now.nanoseconds):
            self._start_throw(now, t)
        self._publish_sensor(None if self.motion is None else pose)
        self._publish_joint_and_pose(now, pose, velocity)
        self._feed_tick(now)  # before record_tick: the goal's coroutine wakes to a decided tick
        self.record_tick(self.simulated * 1e-9)

    def _advance_clock(self, now: Time) -> None:
        """Advance the simulated time by the node-clock time since the last tick, capped per tick."""
        if self.last_tick is not None:
            # Activated before the node clock started: the model starts at the clock's first reading.
            last = self.last_tick.nanoseconds or self.clock_origin_ns() or now.nanoseconds
            elapsed = max(now.nanoseconds - last, 0)
            self.simulated += min(elapsed, _ns(MAX_TICK_PERIODS / self.p["sensor_rate"]))
        self.last_tick = now

    def _throw_due(self, t: int, now_ns: int) -> bool:
        """Return whether a throw is wanted (running, queued, or a feed goal's), allowed, and due."""
        feed = self.feed is not None and self.feed.wants_throw(now_ns)
        wanted = self.running or self.pending > 0 or feed
        ready = self.state() in (DeviceState.IDLE, DeviceState.RUNNING)
        waited = self.last_throw is None or t - self.last_throw >= _ns(self.p["period"])
        return wanted and ready and waited

    def _start_throw(self, now: Time, t: int) -> None:
        """Throw once; show it over the motion window, or report a fault at once (FAULT_PART_LOST)."""
        arm, faults = self._model(), self._faults_model()
        if self.pending > 0:
            self.pending -= 1
        self.last_throw = t
        outcome = faults.throw()
        self.throws += 1
        if self.feed is not None:
            self.feed.throw_started()
        if outcome.kind == "fault":
            self._cancel_commands()
            self.fault_count += 1
            self._publish_event(now, outcome)
            self.raise_model_fault(
                DeviceStatus.FAULT_PART_LOST,
                f"throw {self.throws}: {outcome.fault} (~/place_part puts it back)",
            )
        else:
            self.motion = (t, outcome, arm.params.speed * faults.last_speed_scale)
            self.publish_status()

    def _advance_motion(
        self, now: Time, t: int, rest: Pose, start: int, outcome: ThrowOutcome, speed: float
    ) -> tuple[Pose, float]:
        """Return the pose and joint velocity shown of the throw begun at ``start``; publish it at the end."""
        window = _ns(self.p["period"] * self.p["motion_fraction"])
        if t - start >= window:
            self.motion = None
            self._publish_event(now, outcome)
            return rest, 0.0
        return self._animate(outcome, (t - start) / window, speed)

    def _publish_sensor(self, pose: Pose | None) -> None:
        """Publish the sensor bit (at rest, or for the pose shown in flight) as the faults deliver it."""
        reading = self._model().sensor(self.p["sensor_radius"], self.p["sensing_height"], pose)
        delivered = self._faults_model().sensor(reading)
        if delivered is not None:
            self.last_bit = delivered
            self.pub_sensor.publish(Bool(data=delivered))
        if pose is None and self.feed is not None:
            self.feed.sample(delivered)  # the bit as published decides, faults and all

    def _publish_joint_and_pose(self, now: Time, pose: Pose, velocity: float) -> None:
        """Publish the arm joint state, and the part pose in the arm frame while the part is on the arm."""
        stamp = now.to_msg()
        joint = JointState()
        joint.header.stamp = stamp
        joint.name, joint.position, joint.velocity, joint.effort = ["arm_joint"], [0.0], [velocity], [0.0]
        self.shown = (pose, joint.position[0])
        self.pub_joint.publish(joint)
        if not self._model().on_arm:
            return  # nothing on the arm to locate
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.frame_id
        msg.pose.position.x, msg.pose.position.y = pose[0], pose[1]
        msg.pose.orientation = yaw_quaternion(pose[2])
        self.pub_pose.publish(msg)

    def drawing(self) -> Drawing | None:
        """Return what ~/markers shows: the arm at its joint angle, the part on it, the sensor by its bit."""
        arm = self.arm
        if arm is None:
            return None
        pose, joint = self.shown if self.shown is not None else (arm.rest_pose(), 0.0)
        length = display_length(arm.arm_length, arm.radius, arm.part.radius, self.p["sensor_radius"])
        width = 0.01 * length
        offset = arm.params.offset
        sensor = self.p["sensor_radius"], offset, self.p["sensing_height"], self.last_bit, width
        shapes = arm_shapes(length, offset, joint, width) + sensor_shapes(*sensor)
        if arm.on_arm:
            if self.part_triangles[0] is not arm.part:
                self.part_triangles = (arm.part, triangulate_loops(arm.part.part.loops()))
            shapes += part_on_arm_shapes(arm.part.part, pose, self.part_triangles[1])
        return Drawing(self.frame_id, self.frame_id, dynamic=shapes)

    def _animate(self, outcome: ThrowOutcome, fraction: float, speed: float) -> tuple[Pose, float]:
        """Return the pose along the flight path and the joint velocity (the arm moves only at release)."""
        path = outcome.path
        velocity = speed if fraction < RELEASE_SHOWN else 0.0
        if not path:
            return self._model().rest_pose(), velocity
        index = min(int(fraction / FLIGHT_SHOWN * (len(path) - 1)), len(path) - 1)
        _, x, y, theta = path[index]
        return (x, y, theta), velocity

    def _publish_event(self, now: Time, outcome: ThrowOutcome) -> None:
        """Publish the throw event: states before and after, kind, fault, the (true) sensor at rest."""
        arm = self._model()
        ev = ThrowEvent()
        ev.header.stamp, ev.header.frame_id = now.to_msg(), self.frame_id
        ev.index = self.throws
        ev.edge_before, ev.radius_before = outcome.edge_before, outcome.radius_before
        ev.edge_after, ev.radius_after = outcome.edge_after, outcome.radius_after
        ev.kind, ev.turns, ev.rotation = outcome.kind, outcome.turns, outcome.rotation
        ev.fault, ev.fault_reason = outcome.kind == "fault", outcome.fault
        ev.sensor_at_rest = bool(arm.sensor(self.p["sensor_radius"], self.p["sensing_height"]))
        ev.fidelity = self.p["fidelity"]
        # The paper model's assumptions this throw broke (issue 14); off_arm made it a part lost above.
        ev.lift_off, ev.slip = "lift_off" in outcome.flags, "slip" in outcome.flags
        ev.off_arm, ev.toe_stub = "off_arm" in outcome.flags, "toe_stub" in outcome.flags
        if ev.sensor_at_rest and not ev.fault:
            self.presented += 1
        self.pub_event.publish(ev)
        if self.feed is not None:
            self.feed.landed(now.nanoseconds, *self._ground_truth(), ev)
        self.publish_status()

    # --- ~/feed_part ----------------------------------------------------------------------------------
    def _validate_feed(self, goal: FeedPart.Goal) -> None:
        """Refuse a bad goal naming the field, or a goal while ~/command keeps the arm busy."""
        check_feed_goal(int(goal.max_throws), float(goal.timeout))
        if self.running or self.pending > 0 or self.motion is not None:
            doing = (
                "throwing every period"
                if self.running
                else f"{self.pending} throw(s) queued"
                if self.pending
                else "a throw in flight"
            )
            raise DeviceError(
                f"~/feed_part goal refused: ~/command keeps the arm busy ({doing}); "
                "~/command stop, or wait for IDLE"
            )

    async def _execute_feed(self, handle: ServerGoalHandle) -> FeedPart.Result:
        """Run an accepted goal tick by tick until it ends; never outlives the device's activity."""
        goal = handle.request
        request = check_feed_goal(int(goal.max_throws), float(goal.timeout))
        now = self.get_clock().now()
        feed: FeedGoal[ThrowEvent] = FeedGoal(
            request, now.nanoseconds, self._rest_window_ns(), *self._ground_truth()
        )
        self.feed = feed
        self.feed_goals += 1
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        poll = self.create_timer(CANCEL_POLL, lambda: self._poll_cancel(handle), clock=steady)
        self.get_logger().info(
            f"~/feed_part: goal accepted (max_throws {request.max_throws}, timeout {request.timeout:g} s)"
        )
        self.publish_status()
        try:
            while True:
                self._send_feedback(handle, feed)
                if feed.done:
                    break
                if not self.active or self.arm is None:
                    feed.end_now(
                        "FAULT",
                        f"device {self.state().name} (deactivated) during the goal: the physics is frozen "
                        "and no throw can land; activate it and send a new goal",
                        DeviceStatus.FAULT_NONE,
                        f"device {self.state().name}",
                    )
                    continue
                if handle.is_cancel_requested and not feed.cancel_reason:
                    feed.cancel("canceled by its client")
                    self._feed_tick(self.get_clock().now())  # at rest it ends now, held clock or not
                    continue
                self._feed_waiter = self.next_tick()
                await self._feed_waiter
        finally:
            self.destroy_timer(poll)
            self._feed_waiter = None
            self.feed = None
        return self._feed_result(handle, feed)

    def _feed_tick(self, now: Time) -> None:
        """Tell the goal the tick is over (judge the bit, end, or ask for a throw)."""
        if self.feed is not None:
            self.feed.tick(now.nanoseconds, self.stopping_fault(), self.motion is not None)

    def _poll_cancel(self, handle: ServerGoalHandle) -> None:
        """Wake the goal for a cancel (under a held node clock no tick would)."""
        if handle.is_cancel_requested:
            self._wake_feed()

    def _wake_feed(self) -> None:
        waiter = self._feed_waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(self.active)

    def _send_feedback(self, handle: ServerGoalHandle, feed: FeedGoal[ThrowEvent]) -> None:
        """Publish one feedback per throw the goal has judged, in order."""
        reports, feed.reports = feed.reports, []
        for report in reports:
            handle.publish_feedback(
                FeedPart.Feedback(
                    throws=report.throws,
                    sensor_at_rest=report.sensor_at_rest,
                    edge=report.edge,
                    radius=report.radius,
                    event=report.event if report.event is not None else ThrowEvent(),
                )
            )

    def _feed_result(self, handle: ServerGoalHandle, feed: FeedGoal[ThrowEvent]) -> FeedPart.Result:
        """Set the goal's terminal state and return its result (the outcome's code and name)."""
        outcome = feed.outcome
        assert outcome is not None  # the loop above only leaves once the goal ended
        # The arm's state now is the ground truth after the goal's last throw, and says (-1, NaN)
        # when the part has left the arm, which the goal itself never saw land.
        edge, radius = self._ground_truth()
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
        if outcome.name == "PRESENTED":
            self.feeds_presented += 1
            handle.succeed()
        elif outcome.name == "CANCELED" and handle.is_cancel_requested:
            handle.canceled()
        else:
            handle.abort()
        # rclpy refuses one call site logging at two severities: one call each.
        if outcome.name == "PRESENTED":
            self.get_logger().info(f"~/feed_part: {outcome.name}: {outcome.message}")
        else:
            self.get_logger().warning(f"~/feed_part: {outcome.name}: {outcome.message}")
        return result

    def _rest_window_ns(self) -> int:
        """Return the longest wait (ns) for a delivered sensor sample once the part is at rest.

        The rest time between throws less one sample: an unread bit then asks for the next throw in
        time for it to start a period after the last one, as if the bit had been read.
        """
        rest = self.p["period"] * (1.0 - self.p["motion_fraction"]) - 1.0 / self.p["sensor_rate"]
        return _ns(max(rest, 0.0))

    def _ground_truth(self) -> tuple[int, float]:
        """Return (edge, R) of the part at rest, or (-1, NaN) when it is not on the arm (for logging)."""
        arm = self.arm
        if arm is None or not arm.on_arm:
            return -1, math.nan
        return arm.edge, arm.radius


def _ns(seconds: float) -> int:
    """Return a duration in integer nanoseconds."""
    return int(round(seconds * 1e9))


def _throw_params(p: dict[str, Any]) -> ThrowParams:
    """Return the design parameters; an InputError names the parameter."""
    try:
        return ThrowParams(p["offset"], p["release_speed"], p["gravity"], p["mu"])
    except InputError as error:
        raise InputError(f"parameter {error.field}", error.problem) from None


def main(args: list[str] | None = None) -> None:
    """Run the throwing_arm node."""
    run_node(ThrowingArmNode, "throwing_arm", args)


if __name__ == "__main__":
    main()
