"""The assembly fixture's ROS message adapters: its streams from the table, and the ~/follow_path goal.

The node (``feeder_sim.nodes.assembly_fixture``) publishes what these build; ``FollowPathGoal`` is the
kit's goal runner's view of the ROS-free ``fixture.path_goal.PathGoal``.
"""

from __future__ import annotations

import math
from typing import Protocol, Sequence

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.clock import Clock
from rclpy.impl.rcutils_logger import RcutilsLogger
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from feeder_device.declarations import Counters
from feeder_device.device import DeviceState
from feeder_msgs.action import FollowPath
from feeder_msgs.msg import StabilityStatus
from feeder_msgs.srv import FixtureMove
from feeder_planner.assembly import PreparedAssembly
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit import from_vec, vec
from feeder_planner.node_kit.msg_assembly import force_msgs
from feeder_planner.node_kit.request_limits import MAX_WAYPOINTS, check_count
from feeder_sim.fixture import (
    JOINT_NAMES,
    GoalWaypoints,
    PathVerdict,
    PlannedPath,
    Table,
    TableLimits,
    goal_waypoints,
    gravity_of,
)
from feeder_sim.fixture.parameters import FixtureParameters
from feeder_sim.fixture.path_goal import PathGoal, PathOutcome
from feeder_sim.fixture.stability import stability_result
from feeder_sim.fixture.station import FixtureStation

__all__ = [
    "FOLLOW_PATH",
    "FollowPathGoal",
    "PathFixture",
    "fill_move_response",
    "follow_path_waypoints",
    "gravity_msg",
    "joint_state_msg",
    "move_waypoints",
    "stability_msg",
]

FOLLOW_PATH = "~/follow_path"


def joint_state_msg(header: Header, reading: np.ndarray, velocity: np.ndarray) -> JointState:
    """Return the joints as the encoders read them, and their rates."""
    return JointState(
        header=header, name=list(JOINT_NAMES), position=reading.tolist(), velocity=velocity.tolist()
    )


def gravity_msg(header: Header, reading: np.ndarray) -> Vector3Stamped:
    """Return the gravity direction of the joints as the encoders read them."""
    return Vector3Stamped(header=header, vector=vec(gravity_of(reading)))


def stability_msg(header: Header, prepared: PreparedAssembly, g: np.ndarray, moving: bool) -> StabilityStatus:
    """Return the LP's verdict at the true gravity ``g``: stable, margin, unbalanced bodies, forces."""
    status = StabilityStatus(header=header, gravity=vec(g), moving=moving)
    try:
        result = stability_result(prepared, g)  # solved again only when g changed (fixture/stability.py)
        status.stable = result.stable
        status.margin = result.margin_rad
        status.unbalanced_bodies = list(result.unbalanced_bodies)
        status.forces = force_msgs(result.forces)
    except FeederError as error:  # an uncertified LP is reported, never published as stable
        status.stable = False
        status.margin = math.nan
        status.unbalanced_bodies = [f"(not certified: {error})"]
    return status


def move_waypoints(request: FixtureMove.Request) -> list[np.ndarray]:
    """Return a ~/move request's gravity waypoints (InputError names the field)."""
    if not request.waypoints:
        raise InputError("waypoints", "needs at least one gravity direction")
    check_count(len(request.waypoints), MAX_WAYPOINTS, "waypoints", "waypoints")
    return [from_vec(w, f"waypoints[{i}]") for i, w in enumerate(request.waypoints)]


def fill_move_response(response: FixtureMove.Response, planned: PlannedPath, verdict: PathVerdict) -> None:
    """Say in a ~/move response how many samples the path has, where it is unstable, and how long it takes."""
    response.samples = len(planned.samples)
    response.first_unstable_sample = verdict.first_unstable
    response.unbalanced_bodies = list(verdict.unbalanced_bodies)
    response.duration = planned.path.duration


def follow_path_waypoints(goal: FollowPath.Goal, limits: TableLimits) -> GoalWaypoints:
    """Return a ~/follow_path goal's waypoints, gravity or tilt (InputError names the field)."""
    check_count(len(goal.gravity_waypoints), MAX_WAYPOINTS, "gravity_waypoints", "waypoints")
    check_count(len(goal.tilt_waypoints) // 2, MAX_WAYPOINTS, "tilt_waypoints", "waypoints")
    return goal_waypoints(
        [(v.x, v.y, v.z) for v in goal.gravity_waypoints], list(goal.tilt_waypoints), limits
    )


class PathFixture(Protocol):
    """What ``FollowPathGoal`` needs of the fixture node (a protocol: no import of the node module)."""

    p: FixtureParameters
    stopped: bool
    count: Counters
    table: Table | None
    station: FixtureStation | None
    last_stability: tuple[bool, float]

    def reading(self) -> np.ndarray:
        """Return the last tick's encoder reading."""
        ...

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


class FollowPathGoal:
    """The runner's view of a ``PathGoal``: feedback and result as FollowPath messages, built at the tick."""

    def __init__(self, node: PathFixture, result: FollowPath.Result) -> None:
        self.node, self.answer = node, result
        self.machine: PathGoal | None = None
        self.early: PathOutcome | None = None  # a goal that ended before the table moved
        self.pending: list[FollowPath.Feedback] = []
        self.ended = False

    def ended_early(self, outcome: PathOutcome) -> FollowPathGoal:
        """End the goal before anything moved (not started, not certified, refused by the interlock)."""
        self.early = outcome
        self._finish()
        return self

    def unstable_at(self, verdict: PathVerdict) -> None:
        """Say in the result where the path is first unstable and which bodies the LP cannot balance there."""
        self.answer.first_unstable_sample = verdict.first_unstable
        self.answer.first_unstable_gravity = vec(verdict.samples[verdict.first_unstable])
        self.answer.unbalanced_bodies = list(verdict.unbalanced_bodies)

    def following(self, machine: PathGoal) -> FollowPathGoal:
        """Follow the started path; the first feedback goes out now."""
        self.machine = machine
        self._feedback_if_due()
        return self

    @property
    def outcome(self) -> PathOutcome | None:
        """How the goal ended, or None while it runs."""
        return self.early or (self.machine.outcome if self.machine is not None else None)

    @property
    def done(self) -> bool:
        """Whether the goal has ended."""
        return self.outcome is not None

    def advance(self, now_ns: int, ticked: bool = True) -> None:
        """Decide after a tick (or a cancel); feedback and the result are built from what this tick read."""
        node, machine = self.node, self.machine
        if machine is None or machine.done:
            return
        if node.station is not None:
            node.station.advance_goal(machine, node.stopping_fault(), node.stopped, ticked)
        self._feedback_if_due()
        self._finish()

    def cancel(self, reason: str) -> None:
        """Stop at the next certified sample ahead: at once when the table stands on one."""
        if self.machine is not None:
            self.machine.cancel_requested = True
            self.advance(self.node.get_clock().now().nanoseconds, ticked=False)

    def interrupt(self, reason: str) -> None:
        """End now: the device left active; the table stops where it is."""
        if self.machine is not None:
            self.machine.interrupt(self.node.state().name)
        self._finish()

    def halt(self) -> None:
        """Stop the table (the guard aborted the goal)."""
        if self.node.table is not None:
            self.node.table.halt()

    def feedback(self) -> Sequence[FollowPath.Feedback]:
        """Return the feedback built since the last call."""
        pending, self.pending = self.pending, []
        return pending

    def result(self) -> tuple[str, FollowPath.Result]:
        """Return the terminal state and the result built when the goal ended."""
        outcome = self.outcome
        assert outcome is not None  # the runner asks only once the goal ended
        terminal = {"REACHED": "succeed", "CANCELED": "canceled"}.get(outcome.name, "abort")
        return terminal, self.answer

    def _feedback_if_due(self) -> None:
        """Build progress, gravity as the encoders read it, and the last tick's stability verdict."""
        machine = self.machine
        if machine is None or not machine.feedback_due:
            return
        stable, margin = self.node.last_stability
        gravity = vec(gravity_of(self.node.reading()))
        self.pending.append(
            FollowPath.Feedback(progress=machine.progress, gravity=gravity, stable=stable, margin=margin)
        )

    def _finish(self) -> None:
        """Fill the result once the goal ends (the table as the encoders read it); log the outcome."""
        outcome = self.outcome
        if outcome is None or self.ended:
            return
        self.ended = True
        node, result = self.node, self.answer
        if outcome.name == "REACHED":
            node.count.add("path_goals_reached")
        result.outcome, result.outcome_name, result.message = outcome.code, outcome.name, outcome.message
        result.fault_code, result.fault_text = outcome.fault_code, outcome.fault_text
        if node.table is not None:
            reading = node.reading()
            result.tilt = [float(a) for a in reading]
            result.gravity = vec(gravity_of(reading))
        # Two call sites: rclpy refuses one call site logging at two severities.
        if outcome.name == "REACHED":
            node.get_logger().info(f"{FOLLOW_PATH} {outcome.name}: {outcome.message}")
        else:
            node.get_logger().warning(f"{FOLLOW_PATH} {outcome.name}: {outcome.message}")
