"""ROS 2 node: the simulated throwing arm with a one-bit proximity sensor (thin adapter around feeder_sim.throwing)."""

from __future__ import annotations

import math
from typing import Any

from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
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
from feeder_planner.throwing.geometry import arm_part
from feeder_planner.throwing.throw_map import ThrowParams, lowest_radius
from feeder_sim.throwing.arm import FIDELITIES, ThrowingArm

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
    ParameterSpec("dynamic_step", 1e-4, "pymunk step (s) of the dynamic fidelity", positive),
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
        "R at start (m); 0: 1.5 x the lowest throwable radius of the edge",
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
        radius = p["initial_radius"] or 1.5 * lowest_radius(self.part, edge, params)
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
        self.motion: Any = None  # (start time, outcome) while a throw is shown
        self.last_throw = -math.inf
        self.create_timer(1.0 / p["sensor_rate"], self._tick)

    def _on_parameters(self, changes: list[Any]) -> SetParametersResult:
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
        command = request.command.strip().lower()
        if command == "throw":
            if request.count < 1:
                raise InputError("count", f"must be >= 1 for 'throw', got {request.count}")
            self.pending += request.count
        elif command == "start":
            self.running = True
        elif command == "stop":
            self.running, self.pending = False, 0
        else:
            raise InputError("command", f"must be throw, start or stop, got {request.command!r}")
        response.pending = self.pending
        return response

    def _place(self, request: ArmPlacePart.Request, response: ArmPlacePart.Response) -> ArmPlacePart.Response:
        if not math.isfinite(request.radius):
            raise InputError("radius", f"must be finite, got {request.radius!r}")
        self.arm.place(request.edge, request.radius)
        self.motion = None
        return response

    def _tick(self) -> None:
        now = self.get_clock().now()
        t = now.nanoseconds * 1e-9
        period, window = self.p["period"], self.p["period"] * self.p["motion_fraction"]
        pose, velocity = self.arm.rest_pose(), 0.0
        if self.motion is not None:
            start, outcome = self.motion
            if t - start >= window:
                self.motion = None
                self._publish_event(now, outcome)
            else:
                pose, velocity = self._animate(outcome, (t - start) / window)
        elif (self.running or self.pending > 0) and t - self.last_throw >= period:
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
        sensor = self.arm.sensor(
            self.sensor_radius, self.sensing_height, None if self.motion is None else pose
        )
        self.pub_sensor.publish(Bool(data=bool(sensor)))
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

    def _animate(self, outcome: Any, fraction: float) -> tuple[tuple[float, float, float], float]:
        """Pose along the flight path in the first 80 % of the window; the arm moves only at release."""
        path = outcome.path
        velocity = self.p["release_speed"] if fraction < 0.05 else 0.0
        if not path:
            return self.arm.rest_pose(), velocity
        index = min(int(fraction / 0.8 * (len(path) - 1)), len(path) - 1)
        _, x, y, theta = path[index]
        return (x, y, theta), velocity

    def _publish_event(self, now: Any, outcome: Any) -> None:
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
    run_node(ThrowingArmNode, "throwing_arm", args)


if __name__ == "__main__":
    main()
