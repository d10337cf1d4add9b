"""ROS 2 node: the simulated throwing arm with a one-bit proximity sensor (adapts feeder_sim.throwing)."""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from feeder_msgs.msg import ThrowEvent
from feeder_msgs.srv import ArmCommand, ArmPlacePart
from feeder_planner.errors import InputError
from feeder_planner.node_kit import (
    EVENT_DEPTH,
    STREAM_DEPTH,
    ParameterSpec,
    declare_parameters,
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
from feeder_planner.parts import load_part
from feeder_planner.throwing import ThrowParams, arm_part, lowest_radius
from feeder_sim.throwing import DEFAULT_STEP, FIDELITIES, ThrowingArm, ThrowOutcome, parse_command

__all__ = ["PARAMETERS", "ThrowingArmNode", "main"]

# A start-up R of 0 means this multiple of the edge's lowest throwable R: clear of the domain's edge,
# where the left contact vertex barely lifts.
DEFAULT_RADIUS_FACTOR = 1.5
# Display of a throw within its motion window: the flight path fills the first FLIGHT_SHOWN of the window
# (the part then rests), and the joint shows the release speed during the first RELEASE_SHOWN.
FLIGHT_SHOWN = 0.8
RELEASE_SHOWN = 0.05
Pose = tuple[float, float, float]

PARAMETERS = (
    ParameterSpec(
        "part_file",
        "",
        "part file (YAML, contract section 2); required",
        non_empty_string("a part file"),
    ),
    ParameterSpec("offset", -0.005, "h: height of the arm surface above the pivot (m)", finite),
    ParameterSpec("release_speed", math.radians(320), "W: release angular speed (rad/s, > 0)", positive),
    ParameterSpec(
        "gravity",
        -9.66,
        "g: gravity along y (m/s^2, < 0)",
        negative,
    ),
    ParameterSpec("mu", 0.5, "friction coefficient between arm and part (> 0)", positive),
    ParameterSpec(
        "fidelity",
        "analytic",
        "analytic (the paper's model) or dynamic (pymunk, restitution and friction)",
        one_of(FIDELITIES),
    ),
    ParameterSpec("dynamic_step", DEFAULT_STEP, "pymunk step (s) of the dynamic fidelity", positive),
    ParameterSpec("period", 0.5, "time between throws (s, wall clock)", positive),
    ParameterSpec(
        "motion_fraction",
        0.3,
        "fraction of the period spent showing the throw; the rest is at rest",
        in_range(0.0, 1.0, include_low=False, include_high=False),
    ),
    ParameterSpec(
        "sensor_radius", 0.2, "x of the proximity sensor on the arm (m); may change at runtime", finite
    ),
    ParameterSpec(
        "sensing_height",
        0.001,
        "sensing height above the arm surface (m, >= 0); may change at runtime",
        non_negative,
    ),
    ParameterSpec(
        "sensor_rate", 100.0, "rate of the sensor, joint state and part pose topics (Hz)", positive
    ),
    ParameterSpec(
        "initial_edge",
        -1,
        "stable hull edge the part starts on (-1: the first stable edge)",
        integer,
    ),
    ParameterSpec(
        "initial_radius",
        0.0,
        f"R at start (m); 0: {DEFAULT_RADIUS_FACTOR:g} x the lowest throwable radius of the edge",
        non_negative,
    ),
    ParameterSpec(
        "arm_length", 0.4, "length of the arm from the pivot (m); a part beyond it has left the arm", positive
    ),
    ParameterSpec(
        "autostart", False, "throw every period from the start (else wait for a start/throw command)"
    ),
    ParameterSpec("frame_id", "arm_pivot", "frame of the part pose (at the arm pivot, gravity along -y)"),
)


class ThrowingArmNode(Node):
    """Throw-catch cycles at a period; publishes joint state, part pose, throw events and the sensor bit."""

    def __init__(self) -> None:
        super().__init__("throwing_arm")
        p = declare_parameters(self, PARAMETERS)
        self.p = p
        self.part = arm_part(load_part(p["part_file"]))
        params = ThrowParams(p["offset"], p["release_speed"], p["gravity"], p["mu"])
        edge = p["initial_edge"] if p["initial_edge"] >= 0 else self.part.stable_edges[0]
        if not (0 <= edge < self.part.n) or not self.part.stable[edge]:
            raise InputError(
                "parameter initial_edge", f"must be a stable edge {self.part.stable_edges}, got {edge}"
            )
        radius = p["initial_radius"] or DEFAULT_RADIUS_FACTOR * lowest_radius(self.part, edge, params)
        try:
            self.arm = ThrowingArm(
                self.part, params, edge, radius, p["fidelity"], p["arm_length"], p["dynamic_step"]
            )
        except InputError as error:
            raise InputError(f"parameter initial_{error.field}", error.problem) from None
        self.sensor_radius, self.sensing_height = p["sensor_radius"], p["sensing_height"]
        self.add_on_set_parameters_callback(self._on_parameters)
        self.pub_joint = self.create_publisher(JointState, "/throwing_arm/joint_states", STREAM_DEPTH)
        self.pub_pose = self.create_publisher(PoseStamped, "/throwing_arm/part_pose", STREAM_DEPTH)
        self.pub_event = self.create_publisher(ThrowEvent, "/throwing_arm/throw_events", EVENT_DEPTH)
        self.pub_sensor = self.create_publisher(Bool, "/throwing_arm/sensor", EVENT_DEPTH)
        self.create_service(ArmCommand, "/throwing_arm/command", service_guard(self)(self._command))
        self.create_service(ArmPlacePart, "/throwing_arm/place_part", service_guard(self)(self._place))
        self.running, self.pending, self.count = p["autostart"], 0, 0
        self.motion: tuple[float, ThrowOutcome] | None = None  # (start time, outcome) while a throw is shown
        self.last_throw = -math.inf
        self.create_timer(1.0 / p["sensor_rate"], self._tick)

    def _on_parameters(self, changes: list[Parameter]) -> SetParametersResult:
        """Accept runtime changes of the sensor's radius and height only, each checked."""
        for change in changes:
            if change.name in ("sensor_radius", "sensing_height"):
                value = change.value
                bad = finite(value) if change.name == "sensor_radius" else non_negative(value)
                if bad:
                    return SetParametersResult(successful=False, reason=f"{change.name}: {bad}")
            elif change.name in {spec.name for spec in PARAMETERS}:
                return SetParametersResult(successful=False, reason=f"{change.name} is fixed at start-up")
        for change in changes:
            setattr(self, change.name, float(change.value))
        return SetParametersResult(successful=True)

    def _command(self, request: ArmCommand.Request, response: ArmCommand.Response) -> ArmCommand.Response:
        """Queue throws, or start or stop throwing every period."""
        command = parse_command(request.command)
        if command == "throw":
            if request.count < 1:
                raise InputError("count", f"must be >= 1 for 'throw', got {request.count}")
            self.pending += request.count
        elif command == "start":
            self.running = True
        else:  # stop
            self.running, self.pending = False, 0
        response.pending = self.pending
        return response

    def _place(self, request: ArmPlacePart.Request, response: ArmPlacePart.Response) -> ArmPlacePart.Response:
        """Put the part at rest at (edge, R), ending any throw being shown."""
        if not math.isfinite(request.radius):
            raise InputError("radius", f"must be finite, got {request.radius!r}")
        self.arm.place(request.edge, request.radius)
        self.motion = None
        return response

    def _tick(self) -> None:
        """Advance the shown throw or start the next one, then publish the sensor, joint and part pose."""
        now = self.get_clock().now()
        t = now.nanoseconds * 1e-9
        pose, velocity = self.arm.rest_pose(), 0.0
        if self.motion is not None:
            pose, velocity = self._advance_motion(now, t, pose, *self.motion)
        elif self._throw_due(t):
            self._start_throw(now, t)
        self._publish_sensor(None if self.motion is None else pose)
        self._publish_joint_and_pose(now, pose, velocity)

    def _throw_due(self, t: float) -> bool:
        """Return whether a throw is wanted (running, or queued) and a period has passed since the last."""
        return (self.running or self.pending > 0) and t - self.last_throw >= self.p["period"]

    def _start_throw(self, now: Time, t: float) -> None:
        """Throw once; show the throw over the motion window, or report a fault at once and stop."""
        if self.pending > 0:
            self.pending -= 1
        self.last_throw = t
        outcome = self.arm.throw()
        self.count += 1
        if outcome.kind == "fault":
            self.running, self.pending = False, 0
            self.get_logger().error(f"throw {self.count}: FAULT: {outcome.fault}")
            self._publish_event(now, outcome)
        else:
            self.motion = (t, outcome)

    def _advance_motion(
        self, now: Time, t: float, rest: Pose, start: float, outcome: ThrowOutcome
    ) -> tuple[Pose, float]:
        """Return the pose and joint velocity shown of the throw begun at ``start``; publish it at the end."""
        window = self.p["period"] * self.p["motion_fraction"]
        if t - start >= window:
            self.motion = None
            self._publish_event(now, outcome)
            return rest, 0.0
        return self._animate(outcome, (t - start) / window)

    def _publish_sensor(self, pose: Pose | None) -> None:
        """Publish the sensor bit: at rest (``pose`` None) or for the pose shown in flight."""
        sensor = self.arm.sensor(self.sensor_radius, self.sensing_height, pose)
        self.pub_sensor.publish(Bool(data=bool(sensor)))

    def _publish_joint_and_pose(self, now: Time, pose: Pose, velocity: float) -> None:
        """Publish the arm joint state and the part pose in the arm frame."""
        stamp = now.to_msg()
        joint = JointState()
        joint.header.stamp = stamp
        joint.name, joint.position, joint.velocity, joint.effort = ["arm_joint"], [0.0], [velocity], [0.0]
        self.pub_joint.publish(joint)
        msg = PoseStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.p["frame_id"]
        msg.pose.position.x, msg.pose.position.y = pose[0], pose[1]
        msg.pose.orientation = yaw_quaternion(pose[2])
        self.pub_pose.publish(msg)

    def _animate(self, outcome: ThrowOutcome, fraction: float) -> tuple[Pose, float]:
        """Return the pose along the flight path and the joint velocity (the arm moves only at release)."""
        path = outcome.path
        velocity = self.p["release_speed"] if fraction < RELEASE_SHOWN else 0.0
        if not path:
            return self.arm.rest_pose(), velocity
        index = min(int(fraction / FLIGHT_SHOWN * (len(path) - 1)), len(path) - 1)
        _, x, y, theta = path[index]
        return (x, y, theta), velocity

    def _publish_event(self, now: Time, outcome: ThrowOutcome) -> None:
        """Publish the throw event: states before and after, kind, fault, the sensor at rest."""
        ev = ThrowEvent()
        ev.header.stamp, ev.header.frame_id = now.to_msg(), self.p["frame_id"]
        ev.index = self.count
        ev.edge_before, ev.radius_before = outcome.edge_before, outcome.radius_before
        ev.edge_after, ev.radius_after = outcome.edge_after, outcome.radius_after
        ev.kind, ev.turns, ev.rotation = outcome.kind, outcome.turns, outcome.rotation
        ev.fault, ev.fault_reason = outcome.kind == "fault", outcome.fault
        ev.sensor_at_rest = bool(self.arm.sensor(self.sensor_radius, self.sensing_height))
        ev.fidelity = self.p["fidelity"]
        self.pub_event.publish(ev)


def main(args: list[str] | None = None) -> None:
    """Run the throwing_arm node."""
    run_node(ThrowingArmNode, "throwing_arm", args)


if __name__ == "__main__":
    main()
