"""ROS 2 node: a two-axis tilting fixture holding an assembly, with a stability interlock (paper Figs. 1-2)."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from feeder_msgs.msg import StabilityStatus
from feeder_msgs.srv import FixtureMove
from feeder_planner.assembly.planner import prepare
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit import (
    STREAM_DEPTH,
    Check,
    ParameterSpec,
    declare_parameters,
    from_vec,
    in_range,
    positive,
    run_node,
    service_guard,
    vec,
)
from feeder_planner.node_kit.msg_assembly import (
    ASSEMBLY_PARAMETERS,
    contact_force_msgs,
    load_assembly_parameter,
)
from feeder_sim.fixture.interlock import DEFAULT_STEP, certify, sample_waypoints
from feeder_sim.fixture.kinematics import JOINT_NAMES, TableLimits, TimedPath, gravity_of, plan_joint_path


def _angle(low: float, high: float) -> Check:
    return in_range(low, high, unit="rad")


PARAMETERS = ASSEMBLY_PARAMETERS + (
    ParameterSpec(
        "tilt_x_min",
        -math.pi / 2,
        "lower limit of joint tilt_x (rad, about the world x axis)",
        _angle(-math.pi / 2, math.pi / 2),
    ),
    ParameterSpec(
        "tilt_x_max", math.pi / 2, "upper limit of joint tilt_x (rad)", _angle(-math.pi / 2, math.pi / 2)
    ),
    ParameterSpec(
        "tilt_y_min",
        -math.pi,
        "lower limit of joint tilt_y (rad, about the cradle's y axis)",
        _angle(-math.pi, math.pi),
    ),
    ParameterSpec("tilt_y_max", math.pi, "upper limit of joint tilt_y (rad)", _angle(-math.pi, math.pi)),
    ParameterSpec("max_rate_x", 1.0, "maximum speed of joint tilt_x (rad/s)", positive),
    ParameterSpec("max_rate_y", 1.0, "maximum speed of joint tilt_y (rad/s)", positive),
    ParameterSpec("interlock", True, "refuse any commanded path that leaves the stable region (default on)"),
    ParameterSpec("publish_rate", 20.0, "rate of joint_states, gravity and stability (Hz)", positive),
    ParameterSpec("path_step", DEFAULT_STEP, "angle between certified path samples (rad)", positive),
    ParameterSpec("initial_tilt_x", 0.0, "tilt_x at start (rad)", _angle(-math.pi / 2, math.pi / 2)),
    ParameterSpec("initial_tilt_y", 0.0, "tilt_y at start (rad)", _angle(-math.pi, math.pi)),
)


class InterlockRefusal(FeederError):
    """The interlock refused a commanded path."""


class AssemblyFixture(Node):
    """Publishes /assembly_fixture/{joint_states,gravity,stability}; serves /assembly_fixture/move."""

    def __init__(self) -> None:
        super().__init__("assembly_fixture")
        self.p = declare_parameters(self, PARAMETERS)
        self.limits = TableLimits(
            self.p["tilt_x_min"],
            self.p["tilt_x_max"],
            self.p["tilt_y_min"],
            self.p["tilt_y_max"],
            self.p["max_rate_x"],
            self.p["max_rate_y"],
        ).validate()
        assembly = load_assembly_parameter(self.p["assembly_file"])
        self.prepared = prepare(assembly, self.p["mu"] if self.p["override_mu"] else None, self.p["facets"])
        self.region = self.prepared.region
        self.joints = np.array([self.p["initial_tilt_x"], self.p["initial_tilt_y"]])
        for name, value in zip(JOINT_NAMES, self.joints, strict=True):
            low, high = (
                (self.limits.x_min, self.limits.x_max)
                if name == "tilt_x"
                else (self.limits.y_min, self.limits.y_max)
            )
            if not low <= value <= high:
                raise InputError(f"parameter initial_{name}", f"{value} is outside [{low}, {high}]")
        self.velocity = np.zeros(2)
        self.path: TimedPath | None = None
        self.path_start = 0.0
        self.joint_pub = self.create_publisher(JointState, "~/joint_states", STREAM_DEPTH)
        self.gravity_pub = self.create_publisher(Vector3Stamped, "~/gravity", STREAM_DEPTH)
        self.status_pub = self.create_publisher(StabilityStatus, "~/stability", STREAM_DEPTH)
        self.create_service(FixtureMove, "~/move", service_guard(self)(self.on_move))
        self.create_timer(1.0 / self.p["publish_rate"], self.tick)
        self.get_logger().info(
            f"holding {assembly.name}: stable region {self.region.kind}, "
            f"interlock {'on' if self.p['interlock'] else 'OFF'}"
        )

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_move(self, request: FixtureMove.Request, response: FixtureMove.Response) -> FixtureMove.Response:
        if not request.waypoints:
            raise InputError("waypoints", "needs at least one gravity direction")
        waypoints = [from_vec(w, f"waypoints[{i}]") for i, w in enumerate(request.waypoints)]
        self._advance()
        samples = sample_waypoints(gravity_of(self.joints), waypoints, self.p["path_step"])
        path = plan_joint_path(
            samples[1:], self.joints, self.limits
        )  # joint limits checked before anything moves
        verdict = certify(self.prepared, samples)
        response.samples = len(samples)
        response.first_unstable_sample = verdict.first_unstable
        response.unbalanced_bodies = list(verdict.unbalanced_bodies)
        response.duration = path.duration
        if not verdict.stable:
            g = np.round(samples[verdict.first_unstable], 6).tolist()
            what = (
                f"path sample {verdict.first_unstable} of {len(samples)} (g = {g}) is not stable: "
                f"{', '.join(verdict.unbalanced_bodies) or 'the assembly'} would lose equilibrium"
            )
            if self.p["interlock"]:
                raise InterlockRefusal(f"refused by the interlock: {what}")
            response.warning = f"interlock off, moving anyway: {what}"
            self.get_logger().warning(response.warning)
        self.path, self.path_start = path, self._now()
        return response

    def _advance(self) -> None:
        if self.path is None:
            return
        elapsed = self._now() - self.path_start
        self.joints, self.velocity = self.path.at(elapsed)
        if elapsed >= self.path.duration:
            self.path = None

    def tick(self) -> None:
        self._advance()
        stamp = self.get_clock().now().to_msg()
        g = gravity_of(self.joints)
        self.joint_pub.publish(
            JointState(
                name=list(JOINT_NAMES),
                position=self.joints.tolist(),
                velocity=self.velocity.tolist(),
                header=_header(stamp),
            )
        )
        self.gravity_pub.publish(Vector3Stamped(header=_header(stamp), vector=vec(g)))
        status = StabilityStatus(header=_header(stamp), gravity=vec(g), moving=self.path is not None)
        try:
            verdict = self.prepared.check(g)
            status.stable = verdict.stable
            status.margin = self.region.margin(g)
            status.unbalanced_bodies = self.prepared.body_names(verdict.unbalanced)
            if verdict.forces is not None:
                status.forces = contact_force_msgs(self.prepared, verdict.forces)
        except FeederError as error:  # an uncertified LP is reported, never published as stable
            status.stable = False
            status.margin = math.nan
            status.unbalanced_bodies = [f"(not certified: {error})"]
        self.status_pub.publish(status)


def _header(stamp: Time) -> Header:
    return Header(stamp=stamp, frame_id="assembly")


def main(args: list[str] | None = None) -> None:
    run_node(AssemblyFixture, "assembly_fixture", args)


if __name__ == "__main__":
    main()
