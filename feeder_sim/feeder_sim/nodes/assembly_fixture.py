"""ROS 2 node: a two-axis tilting fixture holding an assembly, with a stability interlock (Figs. 1-2)."""

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
from feeder_planner.assembly import check_result, prepare
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
from feeder_planner.node_kit.msg_assembly import ASSEMBLY_PARAMETERS, force_msgs, load_assembly_parameter
from feeder_sim.fixture import (
    INTERLOCK_STEP,
    JOINT_NAMES,
    MAX_RATE,
    TILT_X_RANGE,
    TILT_Y_RANGE,
    TableLimits,
    TimedPath,
    certify,
    gravity_of,
    plan_joint_path,
    sample_waypoints,
)

__all__ = ["PARAMETERS", "AssemblyFixture", "InterlockRefusedError", "main"]


def _angle(limits: tuple[float, float]) -> Check:
    """Parameter check: an angle (rad) within a joint's mechanical range."""
    return in_range(limits[0], limits[1], unit="rad")


PARAMETERS = ASSEMBLY_PARAMETERS + (
    ParameterSpec(
        "tilt_x_min",
        TILT_X_RANGE[0],
        "lower limit of joint tilt_x (rad, about the world x axis)",
        _angle(TILT_X_RANGE),
    ),
    ParameterSpec("tilt_x_max", TILT_X_RANGE[1], "upper limit of joint tilt_x (rad)", _angle(TILT_X_RANGE)),
    ParameterSpec(
        "tilt_y_min",
        TILT_Y_RANGE[0],
        "lower limit of joint tilt_y (rad, about the cradle's y axis)",
        _angle(TILT_Y_RANGE),
    ),
    ParameterSpec("tilt_y_max", TILT_Y_RANGE[1], "upper limit of joint tilt_y (rad)", _angle(TILT_Y_RANGE)),
    ParameterSpec("max_rate_x", MAX_RATE, "maximum speed of joint tilt_x (rad/s)", positive),
    ParameterSpec("max_rate_y", MAX_RATE, "maximum speed of joint tilt_y (rad/s)", positive),
    ParameterSpec("interlock", True, "refuse any commanded path that leaves the stable region (default on)"),
    ParameterSpec("publish_rate", 20.0, "rate of joint_states, gravity and stability (Hz)", positive),
    ParameterSpec("path_step", INTERLOCK_STEP, "angle between certified path samples (rad)", positive),
    ParameterSpec("initial_tilt_x", 0.0, "tilt_x at start (rad)", _angle(TILT_X_RANGE)),
    ParameterSpec("initial_tilt_y", 0.0, "tilt_y at start (rad)", _angle(TILT_Y_RANGE)),
)


class InterlockRefusedError(FeederError):
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
        self.limits.check_start(self.joints)
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
        """Node clock time (s)."""
        return self.get_clock().now().nanoseconds * 1e-9

    def on_move(self, request: FixtureMove.Request, response: FixtureMove.Response) -> FixtureMove.Response:
        """Serve ~/move: plan and time the great arcs through the waypoints; the interlock may refuse them."""
        if not request.waypoints:
            raise InputError("waypoints", "needs at least one gravity direction")
        waypoints = [from_vec(w, f"waypoints[{i}]") for i, w in enumerate(request.waypoints)]
        self._advance()
        samples = sample_waypoints(gravity_of(self.joints), waypoints, self.p["path_step"])
        # Joint limits are checked before anything moves.
        path = plan_joint_path(samples[1:], self.joints, self.limits)
        verdict = certify(self.prepared, samples)
        response.samples = len(samples)
        response.first_unstable_sample = verdict.first_unstable
        response.unbalanced_bodies = list(verdict.unbalanced_bodies)
        response.duration = path.duration
        if not verdict.stable:
            what = verdict.problem()
            if self.p["interlock"]:
                raise InterlockRefusedError(f"refused by the interlock: {what}")
            response.warning = f"interlock off, moving anyway: {what}"
            self.get_logger().warning(response.warning)
        self.path, self.path_start = path, self._now()
        return response

    def _advance(self) -> None:
        """Move the joints along the current path to the present time; drop the path once finished."""
        if self.path is None:
            return
        elapsed = self._now() - self.path_start
        self.joints, self.velocity = self.path.at(elapsed)
        if elapsed >= self.path.duration:
            self.path = None

    def tick(self) -> None:
        """Publish joint states, gravity and the stability status of the current direction."""
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
            result = check_result(self.prepared, g)
            status.stable = result.stable
            status.margin = result.margin_rad
            status.unbalanced_bodies = list(result.unbalanced_bodies)
            status.forces = force_msgs(result.forces)
        except FeederError as error:  # an uncertified LP is reported, never published as stable
            status.stable = False
            status.margin = math.nan
            status.unbalanced_bodies = [f"(not certified: {error})"]
        self.status_pub.publish(status)


def _header(stamp: Time) -> Header:
    """Return a header in the assembly frame."""
    return Header(stamp=stamp, frame_id="assembly")


def main(args: list[str] | None = None) -> None:
    """Run the node until shutdown."""
    run_node(AssemblyFixture, "assembly_fixture", args)


if __name__ == "__main__":
    main()
