"""ROS 2 node: a two-axis tilting fixture holding an assembly, with a stability interlock (Figs. 1-2).

A managed device (thin adapter around ``feeder_sim.fixture``; the kit, ``feeder_device``, owns the lifecycle,
the tick, the streams and the goal runner). Lifecycle: configure loads the assembly and
prepares its stability LP and region, checks the joint limits and the start pose (a bad file or parameter
fails the transition, naming it); activate starts the tick timer and the streams; deactivate freezes the table
where it is (a move in progress resumes from there on activate); cleanup releases the model.

Time: everything is on the node clock (``use_sim_time`` puts it on the cell clock). At every tick of
``publish_rate`` (Hz of the node clock) the table advances by the node-clock time elapsed since the last tick,
but by at most ``max_advance_per_tick`` seconds (0: ``CATCH_UP_PERIODS`` periods, times the real-time factor
when it is above 1); a longer gap is not simulated and the tick is counted (``capped_ticks``), so a fixture
that cannot keep up lags visibly (its simulated time, recorded at every tick, falls behind the clock).

Injected faults (``~/inject_fault`` or the ``inject_faults`` parameter) act through the table model
(``feeder_sim.fixture.faults``); this node only wires them. The encoder faults change what ``~/joint_states``
and ``~/gravity`` report; ``~/stability`` is the model's ground truth: the true gravity and its verdict.

Motion: ``~/move`` (service, no feedback) and the ``~/follow_path`` action (feedback, cancel, result codes)
plan on one code path (``feeder_sim.fixture.follow.plan_path``); one of them moves the table at a time. A
goal (``feeder_sim.fixture.path_goal``) is advanced by the ticks through the device kit's goal runner, so a
held clock holds it.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable, Sequence

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.action.server import ServerGoalHandle
from rclpy.time import Time as RclTime
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from feeder_device.declarations import ActiveFault, DeviceError, FaultSpec
from feeder_device.device import ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import FollowPath
from feeder_msgs.msg import DeviceStatus, StabilityStatus
from feeder_msgs.srv import FixtureMove
from feeder_planner.assembly import PreparedAssembly, check_result, prepare
from feeder_planner.assembly.parameters import load_assembly_parameter
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit import STREAM_DEPTH, from_vec, run_node, service_guard, vec
from feeder_planner.node_kit.msg_assembly import force_msgs
from feeder_planner.node_kit.request_limits import (
    MAX_MOVE_SAMPLES,
    MAX_WAYPOINTS,
    check_arc_samples,
    check_count,
)
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.tf import quaternion_from_matrix
from feeder_planner.node_kit.viz import VIZ_PARAMETERS, DeviceViz, Drawing, MovingFrame
from feeder_sim.fixture import (
    CATCH_UP_PERIODS,
    FAULT_INFO,
    FIXTURE_FAULTS,
    JOINT_NAMES,
    GoalWaypoints,
    PathVerdict,
    PlannedPath,
    Table,
    TableLimits,
    certify,
    check_fault_name,
    goal_waypoints,
    gravity_of,
    plan_goal,
    plan_path,
)
from feeder_sim.fixture.counters import COUNTERS
from feeder_sim.fixture.drawing import body_shapes, gravity_shape, table_rotation, table_shapes
from feeder_sim.fixture.parameters import BASE_FRAME, TABLE_BASE_FRAME, FixtureParameters
from feeder_sim.fixture.path_goal import PathGoal, PathOutcome

__all__ = ["PARAMETERS", "FAULTS", "AssemblyFixtureNode", "InterlockRefusedError", "main"]

NODE_NAME = "assembly_fixture"
NANOSECONDS = 1_000_000_000
FOLLOW_PATH = "~/follow_path"
PARAMETERS = device_parameter_specs(FixtureParameters, VIZ_PARAMETERS)

FAULTS: dict[str, FaultSpec] = {
    name: FaultSpec(
        name,
        f"{FAULT_INFO[name].description} ({FAULT_INFO[name].magnitude})",
        # Empty: the kit's label would print indices as "cells"; status and diagnostics list the name (the
        # log, and for rate_limit the status text, say the axes and the magnitude).
        value_meaning="",
        # axis_stall stops the fixture only once the joint has stalled (raise_model_fault), not on injection.
        stops_device=False,
        code={"axis_stall": DeviceStatus.FAULT_AXIS_STALL, "rate_limit": DeviceStatus.FAULT_RATE_LIMIT}.get(
            name, DeviceStatus.FAULT_NONE
        ),
    )
    for name in FIXTURE_FAULTS
}


class InterlockRefusedError(FeederError):
    """The interlock refused a commanded path."""


class AssemblyFixtureNode(ManagedDevice[FixtureParameters]):
    """Publishes ~/joint_states, ~/gravity and ~/stability at publish_rate; serves ~/move and ~/follow_path.

    ~/move is refused unless the device is ready; the device services of ``ManagedDevice`` (~/stop, ~/reset,
    ~/inject_fault; ~/status, /diagnostics) come with it.
    """

    FAULTS = FAULTS
    COUNTERS = COUNTERS

    def __init__(self) -> None:
        super().__init__(NODE_NAME, FixtureParameters, VIZ_PARAMETERS, rate=20.0)
        self._forget()
        serve(self, FixtureMove, "~/move", service_guard(self)(self._on_move))
        serve_goal(self, FollowPath, FOLLOW_PATH, self._validate_follow_path, self._start_follow_path)
        self.viz = DeviceViz(self, self.drawing)

    def _forget(self) -> None:
        """Forget the model and what the last tick read (the kit destroys the streams, resets counters)."""
        self.table: Table | None = None
        self.prepared: PreparedAssembly | None = None
        self.limits = TableLimits()
        self.frame_id = ""
        # The last tick's encoder reading and stability verdict: the goal's feedback and result say what the
        # streams said (a second reading would draw the encoder noise again and change the streams' sequence).
        self.last_reading: np.ndarray | None = None
        self.last_stability = (False, math.nan)
        self.last_unbalanced: list[str] = []

    # --- configure / cleanup --------------------------------------------------------------------------
    def configure_device(self, p: FixtureParameters) -> None:
        """Load the assembly, prepare its LP and region, build the table; InputError names a bad field."""
        self._forget()
        limits = TableLimits(
            p.tilt_x_min,
            p.tilt_x_max,
            p.tilt_y_min,
            p.tilt_y_max,
            p.max_rate_x,
            p.max_rate_y,
        )
        try:
            limits.validate()
        except InputError as error:
            raise InputError(f"parameter {error.field}", error.problem) from None
        assembly = load_assembly_parameter(p.assembly_file)
        self.prepared = prepare(assembly, p.mu if p.override_mu else None, p.facets)
        self.table = Table(np.array([p.initial_tilt_x, p.initial_tilt_y], float), limits)
        self.limits = limits
        self.frame_id = p.frame_id or self.frame(BASE_FRAME)
        self.expect_rate(p.publish_rate)
        self.joint_pub = self.stream(JointState, "~/joint_states", STREAM_DEPTH)
        self.gravity_pub = self.stream(Vector3Stamped, "~/gravity", STREAM_DEPTH)
        self.stability_pub = self.stream(StabilityStatus, "~/stability", STREAM_DEPTH)
        self.get_logger().info(
            f"holding {assembly.name}: stable region {self.prepared.region.kind}, "
            f"interlock {'on' if p.interlock else 'OFF'}"
        )

    def cleanup_device(self) -> None:
        """Release the model."""
        self._forget()

    # --- runtime parameters, status, stop/reset, faults ---------------------------------------------
    def apply_parameter(self, name: str, p: FixtureParameters) -> None:
        """Apply max_rate_x/y to the running table (the move in progress speeds up or slows down).

        interlock, path_step and max_advance_per_tick are read from ``self.p`` at every move or tick, which
        the kit updates once this returns; every other parameter is read-only.
        """
        if self.table is None or name not in ("max_rate_x", "max_rate_y"):
            return
        if name == "max_rate_x":
            limits = replace(self.limits, rate_x=float(p.max_rate_x))
        else:
            limits = replace(self.limits, rate_y=float(p.max_rate_y))
        try:
            limits.validate()
        except InputError as error:
            raise InputError(f"parameter {name}", error.problem) from None
        self.limits = self.table.limits = limits

    def busy(self) -> bool:
        """Whether a move is in progress or a ~/follow_path goal executes."""
        return super().busy() or (self.table is not None and self.table.moving)

    def stop_device(self) -> None:
        """Halt the table where it is: the move in progress is dropped; moves are refused until ~/reset."""
        if self.table is not None:
            self._advance_to(self.get_clock().now().nanoseconds)
            self.table.halt()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the table model (validated there: InputError naming the field)."""
        if self.table is None:
            return
        self._advance_to(self.get_clock().now().nanoseconds)  # a fault acts from now, not from the last tick
        self.table.faults.inject(
            fault.spec.name,
            self.limits,
            value=fault.value,
            indices=fault.indices,
            angle=fault.angle,
            seed=fault.seed,
        )
        self.get_logger().warning(
            f"injected fault {fault.spec.name}: {self.table.faults.describe(fault.spec.name)}"
        )

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the table model; clearing a stall that acted ends its FAULT."""
        if self.table is None:
            return
        self.table.faults.clear(name)
        if name == "axis_stall" and self.model_fault is not None:
            if self.model_fault[0] == DeviceStatus.FAULT_AXIS_STALL:
                self.model_fault = None

    def warning_fault(self) -> tuple[int, str] | None:
        """Return (code, text) of a coded fault in force that does not stop the fixture (rate_limit)."""
        for name, fault in self.faults.items():
            # axis_stall's code is reported once the joint has stalled (raise_model_fault), not before.
            if fault.spec.code and not FAULT_INFO[check_fault_name(name)].stops:
                detail = self.table.faults.describe(name) if self.table is not None else ""
                return fault.spec.code, f"injected fault {name}: {detail or fault.spec.description}"
        return None

    # --- the move service ----------------------------------------------------------------------------
    def _on_move(self, request: FixtureMove.Request, response: FixtureMove.Response) -> FixtureMove.Response:
        """Serve ~/move: plan and time the great arcs through the waypoints; the interlock may refuse them."""
        try:
            self.require_ready("move")
            self._move(request, response)
        except FeederError:
            self.count.add("refused_moves")
            self.publish_status()
            raise
        self.count.add("moves")
        self.publish_status()
        return response

    def _move(self, request: FixtureMove.Request, response: FixtureMove.Response) -> None:
        """Plan, certify and start a move (raise InputError / InterlockRefusedError to refuse it)."""
        table, prepared = self.table, self.prepared
        assert table is not None and prepared is not None  # require_ready: configured
        if self.goals:
            raise DeviceError(f"move refused: a {FOLLOW_PATH} goal is executing; cancel it first")
        if not request.waypoints:
            raise InputError("waypoints", "needs at least one gravity direction")
        check_count(len(request.waypoints), MAX_WAYPOINTS, "waypoints", "waypoints")
        waypoints = [from_vec(w, f"waypoints[{i}]") for i, w in enumerate(request.waypoints)]
        self._advance_to(self.get_clock().now().nanoseconds)
        self.require_ready("move")  # the table may have stalled on its way here
        # Counted before sampling: every sample is an LP on this single-threaded device (request_limits).
        check_arc_samples(table.gravity(), waypoints, self.p.path_step, "waypoints", MAX_MOVE_SAMPLES)
        # Joint limits are checked before anything moves; the timing is at the rates the axes reach now.
        planned = plan_path(table, waypoints, self.p.path_step)
        verdict = certify(prepared, planned.samples)
        response.samples = len(planned.samples)
        response.first_unstable_sample = verdict.first_unstable
        response.unbalanced_bodies = list(verdict.unbalanced_bodies)
        response.duration = planned.path.duration
        if not verdict.stable:
            what = verdict.problem()
            if self.p.interlock:
                raise InterlockRefusedError(f"refused by the interlock: {what}")
            response.warning = f"interlock off, moving anyway: {what}"
            self.get_logger().warning(response.warning)
        table.start(planned.path)

    # --- the follow_path action ----------------------------------------------------------------------
    def _plan_follow_path(self, goal: FollowPath.Goal) -> tuple[GoalWaypoints, PlannedPath]:
        """Check a goal's waypoints and plan its path from where the table is (InputError names the field)."""
        table = self.table
        assert table is not None  # require_ready: configured
        if table.moving:
            raise DeviceError(f"{FOLLOW_PATH} goal refused: a ~/move is in progress; wait for it or ~/stop")
        check_count(len(goal.gravity_waypoints), MAX_WAYPOINTS, "gravity_waypoints", "waypoints")
        check_count(len(goal.tilt_waypoints) // 2, MAX_WAYPOINTS, "tilt_waypoints", "waypoints")
        waypoints = goal_waypoints(
            [(v.x, v.y, v.z) for v in goal.gravity_waypoints], list(goal.tilt_waypoints), self.limits
        )
        step = self.p.path_step
        check_arc_samples(table.gravity(), waypoints.gravity, step, waypoints.field, MAX_MOVE_SAMPLES)
        return waypoints, plan_goal(table, waypoints, step)

    def _validate_follow_path(self, goal: FollowPath.Goal) -> None:
        """Goal-time check: the waypoints and the joint ranges along the path (not the interlock)."""
        self._plan_follow_path(goal)

    def _start_follow_path(self, handle: ServerGoalHandle) -> FollowPathGoal:
        """Plan and certify the goal's path (REFUSED by the interlock, or started), then follow it."""
        self.count.add("path_goals")
        goal = FollowPathGoal(self, FollowPath.Result(first_unstable_sample=-1))
        try:
            self.require_ready(f"{FOLLOW_PATH} goal")  # the device may have changed since acceptance
            self._advance_to(self.get_clock().now().nanoseconds)
            self.require_ready(f"{FOLLOW_PATH} goal")  # the table may have stalled on its way here
            waypoints, planned = self._plan_follow_path(handle.request)
        except FeederError as error:
            return goal.ended_early(PathOutcome("FAULT", f"not started: {error}"))
        table, prepared = self.table, self.prepared
        assert table is not None and prepared is not None
        try:
            verdict = certify(prepared, planned.samples)
        except FeederError as error:  # an LP that cannot certify ends the goal, never the node
            return goal.ended_early(PathOutcome("FAULT", f"not certified: {error}; the table halted"))
        warning = ""
        if not verdict.stable:
            goal.answer.first_unstable_sample = verdict.first_unstable
            goal.answer.first_unstable_gravity = vec(planned.samples[verdict.first_unstable])
            goal.answer.unbalanced_bodies = list(verdict.unbalanced_bodies)
            if self.p.interlock:
                self.count.add("path_goals_refused")
                refused = f"refused by the interlock: {verdict.problem()}; nothing moved"
                return goal.ended_early(PathOutcome("REFUSED", refused))
            warning = f"interlock off, moving anyway: {verdict.problem()}"
            self.get_logger().warning(f"{FOLLOW_PATH}: {warning}")
        stalls = self.count["stalls"]
        certified = self._certifier(planned, verdict)
        machine = PathGoal(
            table, planned, verdict, waypoints, warning, stalls, certified, DeviceStatus.FAULT_AXIS_STALL
        )
        table.start(planned.path)
        self.publish_status()
        return goal.following(machine)

    def _certifier(self, planned: PlannedPath, verdict: PathVerdict) -> Callable[[int], bool]:
        """Return whether the LP certifies a sample of the path stable (asked only past the first failure)."""
        prepared = self.prepared
        assert prepared is not None

        def certified(sample: int) -> bool:
            if verdict.stable or sample < verdict.first_unstable:
                return True
            return bool(prepared.check(planned.samples[sample]).stable)

        return certified

    def reading(self) -> np.ndarray:
        """Return the last tick's encoder reading (the table's before the first tick)."""
        if self.last_reading is not None:
            return self.last_reading
        assert self.table is not None
        return self.table.reading()

    # --- time and the streams ------------------------------------------------------------------------
    def _max_advance(self) -> float:
        """Return the most simulated time (s) one tick may advance."""
        cap = float(self.p.max_advance_per_tick)
        if cap > 0:
            return cap
        return CATCH_UP_PERIODS * max(1.0, float(self.p.real_time_factor)) / float(self.p.publish_rate)

    def _advance_to(self, now_ns: int) -> None:
        """Advance the table by the node-clock time since the last advance (capped); report a stall."""
        table = self.table
        if table is None or not self.active:
            return
        elapsed = self.elapsed_ns(now_ns) / NANOSECONDS
        cap = self._max_advance()
        if elapsed > cap:
            self.count.add("capped_ticks")
            elapsed = cap
        was_moving = table.moving
        stall = table.advance(elapsed)
        if stall is not None:
            self.count.add("stalls")
            self.raise_model_fault(DeviceStatus.FAULT_AXIS_STALL, stall.describe())
        elif was_moving and not table.moving:
            if not self.goals:  # a goal's end is counted by the goal (path_goals_reached)
                self.count.add("moves_completed")
            self.publish_status()

    def tick(self, now_ns: int) -> float:
        """Advance the table and publish joint states and gravity (as the encoders read) and stability."""
        table, prepared = self.table, self.prepared
        assert table is not None and prepared is not None  # active implies configured
        now = now_ns
        self._advance_to(now)
        header = Header(stamp=RclTime(nanoseconds=now).to_msg(), frame_id=self.frame_id)
        reading = table.reading()
        self.last_reading = reading
        self.joint_pub.publish(
            JointState(
                header=header,
                name=list(JOINT_NAMES),
                position=reading.tolist(),
                velocity=table.velocity.tolist(),
            )
        )
        self.gravity_pub.publish(Vector3Stamped(header=header, vector=vec(gravity_of(reading))))
        g = table.gravity()
        status = StabilityStatus(header=header, gravity=vec(g), moving=table.moving)
        try:
            result = check_result(prepared, g)
            status.stable = result.stable
            status.margin = result.margin_rad
            status.unbalanced_bodies = list(result.unbalanced_bodies)
            status.forces = force_msgs(result.forces)
        except FeederError as error:  # an uncertified LP is reported, never published as stable
            status.stable = False
            status.margin = math.nan
            status.unbalanced_bodies = [f"(not certified: {error})"]
        self.stability_pub.publish(status)
        self.last_stability = (bool(status.stable), float(status.margin))
        self.last_unbalanced = list(status.unbalanced_bodies)
        return table.time

    def drawing(self) -> Drawing | None:
        """Return what ~/markers shows: the table (static), the bodies (unbalanced in red), gravity; the tilt.

        The assembly frame moves on /tf under the fixture's base frame by the true joints (the encoder
        faults change what the streams report, not where the table is).
        """
        table, prepared = self.table, self.prepared
        if table is None or prepared is None:
            return None
        assembly = prepared.assembly
        base = self.frame(TABLE_BASE_FRAME)
        dynamic = [*body_shapes(assembly, self.last_unbalanced), gravity_shape(assembly, table.gravity())]
        rotation = quaternion_from_matrix(table_rotation(table.joints))
        tilt = MovingFrame(base, self.frame_id, (0.0, 0.0, 0.0), rotation)
        return Drawing(self.frame_id, base, static=table_shapes(assembly), dynamic=dynamic, moving=[tilt])


class FollowPathGoal:
    """The runner's view of a ``PathGoal``: feedback and result as FollowPath messages, built at the tick."""

    def __init__(self, node: AssemblyFixtureNode, result: FollowPath.Result) -> None:
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
        every = max(1, math.ceil(float(node.p.publish_rate) / float(node.p.feedback_rate) - 1e-9))
        try:
            machine.advance(node.stopping_fault(), node.stopped, node.count["stalls"], every, ticked)
        except FeederError as error:  # an LP that cannot certify the cancel's stop ends the goal
            machine.table.halt()
            machine.end("FAULT", f"not certified: {error}; the table halted")
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


def main(args: list[str] | None = None) -> None:
    """Run the node until shutdown."""
    run_node(AssemblyFixtureNode, NODE_NAME, args)


if __name__ == "__main__":
    main()
