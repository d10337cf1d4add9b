"""ROS 2 node: a two-axis tilting fixture holding an assembly, with a stability interlock (Figs. 1-2).

A managed device (thin adapter around ``feeder_sim.fixture``). Lifecycle: configure loads the assembly and
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
goal is advanced by the ticks (it awaits ``next_tick``), so a held clock holds it.
"""

from __future__ import annotations

import math
import traceback
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from rclpy.time import Time as RclTime
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from feeder_msgs.action import FollowPath
from feeder_msgs.msg import DeviceStatus, StabilityStatus
from feeder_msgs.srv import FixtureMove
from feeder_planner.assembly import PreparedAssembly, check_result, prepare
from feeder_planner.errors import FeederError, InputError
from feeder_planner.node_kit import (
    STREAM_DEPTH,
    Check,
    ParameterSpec,
    from_vec,
    in_range,
    non_negative,
    positive,
    run_node,
    service_guard,
    vec,
)
from feeder_planner.node_kit.actions import serve_device_action
from feeder_planner.node_kit.device import ActiveFault, DeviceError, FaultSpec, ManagedDevice
from feeder_planner.node_kit.msg_assembly import ASSEMBLY_PARAMETERS, force_msgs, load_assembly_parameter
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
    INTERLOCK_STEP,
    JOINT_NAMES,
    MAX_RATE,
    TILT_X_RANGE,
    TILT_Y_RANGE,
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
from feeder_sim.fixture.drawing import body_shapes, gravity_shape, table_rotation, table_shapes
from feeder_sim.fixture.tolerances import ON_SAMPLE

__all__ = ["PARAMETERS", "FAULTS", "AssemblyFixture", "InterlockRefusedError", "main"]

NODE_NAME = "assembly_fixture"
BASE_FRAME = "assembly"
# The fixture's base (z up), which the cell places and in which the assembly frame tilts (on /tf).
TABLE_BASE_FRAME = "fixture_base"
NANOSECONDS = 1_000_000_000
FOLLOW_PATH = "~/follow_path"
# A running goal looks for a cancel this often (Hz, steady clock) besides at every tick: a table standing on a
# path sample (a goal not yet moved under a held /clock) stops there at once; one between samples needs clock
# time to reach the next, so under a held clock its cancel completes when the clock moves on.
CANCEL_POLL_RATE = 10.0
OUTCOME_NAMES = {
    FollowPath.Result.REACHED: "REACHED",
    FollowPath.Result.REFUSED: "REFUSED",
    FollowPath.Result.STALLED: "STALLED",
    FollowPath.Result.CANCELED: "CANCELED",
    FollowPath.Result.FAULT: "FAULT",
}


def _angle(limits: tuple[float, float]) -> Check:
    """Parameter check: an angle (rad) within a joint's mechanical range."""
    return in_range(limits[0], limits[1], unit="rad")


def _boolean(value: Any) -> str | None:
    """Parameter check: true or false."""
    return None if isinstance(value, bool) else f"must be true or false, got {value!r}"


# Read-only, and why: the assembly parameters define the LP and the region configure prepares (changing them
# means a new model: cleanup and configure); the joint ranges are the mechanism's, checked against the start
# pose at configure (a range shrunk under the table would leave it outside); publish_rate is the timer and
# the configured rate status measures against; the initial tilts only mean something at configure; frame_id
# stamps every stream and a controller keys on it. The runtime ones (interlock, max_rate_x/y, path_step,
# max_advance_per_tick) are read at every move or tick and applied at once.
PARAMETERS = ASSEMBLY_PARAMETERS + (
    ParameterSpec(
        "tilt_x_min",
        TILT_X_RANGE[0],
        "lower limit of joint tilt_x (rad, about the world x axis)",
        _angle(TILT_X_RANGE),
        read_only=True,
    ),
    ParameterSpec(
        "tilt_x_max",
        TILT_X_RANGE[1],
        "upper limit of joint tilt_x (rad)",
        _angle(TILT_X_RANGE),
        read_only=True,
    ),
    ParameterSpec(
        "tilt_y_min",
        TILT_Y_RANGE[0],
        "lower limit of joint tilt_y (rad, about the cradle's y axis)",
        _angle(TILT_Y_RANGE),
        read_only=True,
    ),
    ParameterSpec(
        "tilt_y_max",
        TILT_Y_RANGE[1],
        "upper limit of joint tilt_y (rad)",
        _angle(TILT_Y_RANGE),
        read_only=True,
    ),
    ParameterSpec(
        "max_rate_x",
        MAX_RATE,
        "maximum speed of joint tilt_x (rad/s); at run time it retimes the move",
        positive,
    ),
    ParameterSpec(
        "max_rate_y",
        MAX_RATE,
        "maximum speed of joint tilt_y (rad/s); at run time it retimes the move",
        positive,
    ),
    ParameterSpec(
        "interlock",
        True,
        "refuse any commanded path that leaves the stable region (default on; applies to the next move)",
        _boolean,
    ),
    ParameterSpec(
        "publish_rate", 20.0, "rate of joint_states, gravity and stability (Hz)", positive, read_only=True
    ),
    ParameterSpec(
        "feedback_rate",
        10.0,
        "most ~/follow_path feedback messages per second of the node clock: one every "
        "ceil(publish_rate / feedback_rate) ticks, and always the first and the last; read at every tick",
        positive,
    ),
    ParameterSpec(
        "path_step",
        INTERLOCK_STEP,
        "angle between certified path samples (rad); applies to the next move",
        positive,
    ),
    ParameterSpec("initial_tilt_x", 0.0, "tilt_x at configure (rad)", _angle(TILT_X_RANGE), read_only=True),
    ParameterSpec("initial_tilt_y", 0.0, "tilt_y at configure (rad)", _angle(TILT_Y_RANGE), read_only=True),
    ParameterSpec(
        "max_advance_per_tick",
        0.0,
        f"most node-clock time (s) one tick simulates; a longer gap is not simulated (the table lags, "
        f"visibly); 0: {CATCH_UP_PERIODS:g} periods of publish_rate, times real_time_factor when above 1",
        non_negative,
    ),
    ParameterSpec(
        "frame_id",
        "",
        f"frame of every stream (the assembly frame); empty: {BASE_FRAME} under the node's namespace",
        read_only=True,
    ),
    *VIZ_PARAMETERS,
)

FAULTS = {
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


@dataclass
class _PathGoal:
    """A ~/follow_path goal in progress: its planned path and verdict, feedback and cancel bookkeeping."""

    planned: PlannedPath
    verdict: PathVerdict
    waypoints: GoalWaypoints
    warning: str
    stalls_at_start: int
    ticks: int = 0
    stop_sample: int = -1  # where a cancel stops (-1: not canceled)
    stop_certified: bool = True
    dropped: int = 0  # waypoints of the path a cancel took off its end (the table's count no longer has them)
    progress: float = 0.0


class AssemblyFixture(ManagedDevice):
    """Publishes ~/joint_states, ~/gravity and ~/stability at publish_rate; serves ~/move.

    ~/move is refused unless the device is ready; the device services of ``ManagedDevice`` (~/stop, ~/reset,
    ~/inject_fault; ~/status, /diagnostics) come with it.
    """

    FAULTS = FAULTS

    def __init__(self) -> None:
        super().__init__(NODE_NAME, PARAMETERS, rate=20.0)
        self._release()
        # Kit workaround: ManagedDevice reports a fault code only for a stopping fault; rate_limit has a code
        # (FAULT_RATE_LIMIT) but does not stop the fixture, so status and diagnostics are amended here.
        serve(self, FixtureMove, "~/move", service_guard(self)(self.on_move))
        serve_device_action(self, FollowPath, FOLLOW_PATH, self._validate_follow, self._execute_follow)
        self.viz = DeviceViz(self, self.drawing)

    def _release(self) -> None:
        """Forget the model and everything configure or activate made (publishers, timer)."""
        self.table: Table | None = None
        self.prepared: PreparedAssembly | None = None
        self.limits = TableLimits()
        self.frame_id = ""
        self.timer: Any = None
        self.publishers_made: list[Any] = []
        self.last_tick_ns = 0
        self.count = {
            "moves": 0,
            "refused_moves": 0,
            "moves_completed": 0,
            "stalls": 0,
            "capped_ticks": 0,
            "path_goals": 0,
            "path_goals_reached": 0,
            "path_goals_refused": 0,
        }
        self.goal: _PathGoal | None = None
        # The last tick's encoder reading and stability verdict: the goal's feedback and result say what the
        # streams said (a second reading would draw the encoder noise again and change the streams' sequence).
        self.last_reading: np.ndarray | None = None
        self.last_stability = (False, math.nan)
        self.last_unbalanced: list[str] = []

    # --- configure / activate / deactivate / cleanup ----------------------------------------------
    def configure_device(self, p: dict[str, Any]) -> None:
        """Load the assembly, prepare its LP and region, build the table; InputError names a bad field."""
        self._release()
        limits = TableLimits(
            p["tilt_x_min"],
            p["tilt_x_max"],
            p["tilt_y_min"],
            p["tilt_y_max"],
            p["max_rate_x"],
            p["max_rate_y"],
        )
        try:
            limits.validate()
        except InputError as error:
            raise InputError(f"parameter {error.field}", error.problem) from None
        assembly = load_assembly_parameter(p["assembly_file"])
        self.prepared = prepare(assembly, p["mu"] if p["override_mu"] else None, p["facets"])
        self.table = Table([p["initial_tilt_x"], p["initial_tilt_y"]], limits)
        self.limits = limits
        self.frame_id = p["frame_id"] or self.frame(BASE_FRAME)
        self.expect_rate(p["publish_rate"])
        self.joint_pub = self._publisher(JointState, "~/joint_states")
        self.gravity_pub = self._publisher(Vector3Stamped, "~/gravity")
        self.stability_pub = self._publisher(StabilityStatus, "~/stability")
        self.get_logger().info(
            f"holding {assembly.name}: stable region {self.prepared.region.kind}, "
            f"interlock {'on' if p['interlock'] else 'OFF'}"
        )

    def _publisher(self, msg_type: Any, topic: str) -> Any:
        """Create a lifecycle publisher of a stream, which cleanup destroys."""
        publisher = self.create_lifecycle_publisher(msg_type, topic, STREAM_DEPTH)
        self.publishers_made.append(publisher)
        return publisher

    def activate_device(self) -> None:
        """Start the table from now: the paused time is not simulated."""
        self.last_tick_ns = self.get_clock().now().nanoseconds
        self.timer = self.create_timer(1.0 / self.p["publish_rate"], self.tick)

    def deactivate_device(self) -> None:
        """Freeze the table where it is: the timer goes, the joints and the move in progress stay."""
        if self.timer is not None:
            self.destroy_timer(self.timer)
            self.timer = None

    def cleanup_device(self) -> None:
        """Release the model, the timer and every publisher configure made."""
        self.deactivate_device()
        for publisher in self.publishers_made:
            self.destroy_lifecycle_publisher(publisher)
        self._release()

    # --- runtime parameters, status, stop/reset, faults ---------------------------------------------
    def apply_parameter(self, name: str, value: Any) -> None:
        """Apply max_rate_x/y to the running table (the move in progress speeds up or slows down).

        interlock, path_step and max_advance_per_tick are read from ``self.p`` at every move or tick, which
        the kit updates once this returns; every other parameter is read-only.
        """
        if self.table is None or name not in ("max_rate_x", "max_rate_y"):
            return
        field = "rate_x" if name == "max_rate_x" else "rate_y"
        limits = replace(self.limits, **{field: float(value)})
        try:
            limits.validate()
        except InputError as error:
            raise InputError(f"parameter {name}", error.problem) from None
        self.limits = self.table.limits = limits

    def busy(self) -> bool:
        """Whether a move is in progress or a ~/follow_path goal executes."""
        return self.goal is not None or (self.table is not None and self.table.moving)

    def counters(self) -> dict[str, int]:
        """Return moves accepted, refused, completed, axis stalls, capped ticks, and path goals.

        ``path_goals`` counts accepted ~/follow_path goals, ``path_goals_reached`` those that reached the last
        waypoint and ``path_goals_refused`` those the interlock refused; the ``moves`` counters are ~/move's.
        """
        return dict(self.count)

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
    def on_move(self, request: FixtureMove.Request, response: FixtureMove.Response) -> FixtureMove.Response:
        """Serve ~/move: plan and time the great arcs through the waypoints; the interlock may refuse them."""
        try:
            self.require_ready("move")
            self._move(request, response)
        except FeederError:
            self.count["refused_moves"] += 1
            self.publish_status()
            raise
        self.count["moves"] += 1
        self.publish_status()
        return response

    def _move(self, request: FixtureMove.Request, response: FixtureMove.Response) -> None:
        """Plan, certify and start a move (raise InputError / InterlockRefusedError to refuse it)."""
        table, prepared = self.table, self.prepared
        assert table is not None and prepared is not None  # require_ready: configured
        if self.goal is not None:
            raise DeviceError(f"move refused: a {FOLLOW_PATH} goal is executing; cancel it first")
        if not request.waypoints:
            raise InputError("waypoints", "needs at least one gravity direction")
        check_count(len(request.waypoints), MAX_WAYPOINTS, "waypoints", "waypoints")
        waypoints = [from_vec(w, f"waypoints[{i}]") for i, w in enumerate(request.waypoints)]
        self._advance_to(self.get_clock().now().nanoseconds)
        self.require_ready("move")  # the table may have stalled on its way here
        # Counted before sampling: every sample is an LP on this single-threaded device (request_limits).
        check_arc_samples(table.gravity(), waypoints, self.p["path_step"], "waypoints", MAX_MOVE_SAMPLES)
        # Joint limits are checked before anything moves; the timing is at the rates the axes reach now.
        planned = plan_path(table, waypoints, self.p["path_step"])
        verdict = certify(prepared, planned.samples)
        response.samples = len(planned.samples)
        response.first_unstable_sample = verdict.first_unstable
        response.unbalanced_bodies = list(verdict.unbalanced_bodies)
        response.duration = planned.path.duration
        if not verdict.stable:
            what = verdict.problem()
            if self.p["interlock"]:
                raise InterlockRefusedError(f"refused by the interlock: {what}")
            response.warning = f"interlock off, moving anyway: {what}"
            self.get_logger().warning(response.warning)
        table.start(planned.path)

    # --- the follow_path action ----------------------------------------------------------------------
    def _plan_follow(self, goal: FollowPath.Goal) -> tuple[GoalWaypoints, PlannedPath]:
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
        step = self.p["path_step"]
        check_arc_samples(table.gravity(), waypoints.gravity, step, waypoints.field, MAX_MOVE_SAMPLES)
        return waypoints, plan_goal(table, waypoints, step)

    def _validate_follow(self, goal: FollowPath.Goal) -> None:
        """Goal-time check: the waypoints and the joint ranges along the path (not the interlock)."""
        self._plan_follow(goal)

    async def _execute_follow(self, handle: ServerGoalHandle) -> FollowPath.Result:
        """Run an accepted goal: certify the path, follow it tick by tick, end it with an outcome."""
        self.count["path_goals"] += 1
        result = FollowPath.Result(first_unstable_sample=-1)
        try:
            return await self._run_follow(handle, result)
        except Exception as error:  # a bug (or an LP that cannot certify) ends the goal, never the node
            if self.table is not None:
                self.table.halt()
            if isinstance(error, FeederError):
                message = f"not certified: {error}"
            else:
                self.get_logger().error(f"{FOLLOW_PATH} failed:\n{traceback.format_exc()}")
                message = f"internal error: {type(error).__name__}: {error}"
            return self._finish(handle, result, FollowPath.Result.FAULT, f"{message}; the table halted")
        finally:
            self.goal = None

    async def _run_follow(self, handle: ServerGoalHandle, result: FollowPath.Result) -> FollowPath.Result:
        """Plan and certify the goal's path (REFUSED by the interlock, or started), then follow it."""
        prepared = self.prepared
        try:
            self.require_ready(f"{FOLLOW_PATH} goal")  # the device may have changed since acceptance
            self._advance_to(self.get_clock().now().nanoseconds)
            self.require_ready(f"{FOLLOW_PATH} goal")  # the table may have stalled on its way here
            waypoints, planned = self._plan_follow(handle.request)
        except FeederError as error:
            return self._finish(handle, result, FollowPath.Result.FAULT, f"not started: {error}")
        assert self.table is not None and prepared is not None
        verdict = certify(prepared, planned.samples)
        warning = ""
        if not verdict.stable:
            result.first_unstable_sample = verdict.first_unstable
            result.first_unstable_gravity = vec(planned.samples[verdict.first_unstable])
            result.unbalanced_bodies = list(verdict.unbalanced_bodies)
            if self.p["interlock"]:
                self.count["path_goals_refused"] += 1
                return self._finish(
                    handle,
                    result,
                    FollowPath.Result.REFUSED,
                    f"refused by the interlock: {verdict.problem()}; nothing moved",
                )
            warning = f"interlock off, moving anyway: {verdict.problem()}"
            self.get_logger().warning(f"{FOLLOW_PATH}: {warning}")
        goal = self.goal = _PathGoal(planned, verdict, waypoints, warning, self.count["stalls"])
        self.table.start(planned.path)
        self.publish_status()
        self._send_feedback(handle, goal)
        wake: list[Future] = []

        def poll_cancel() -> None:
            if handle.is_cancel_requested and goal.stop_sample < 0 and wake and not wake[-1].done():
                wake[-1].set_result(False)

        poll = self.create_timer(
            1.0 / CANCEL_POLL_RATE, poll_cancel, clock=Clock(clock_type=ClockType.STEADY_TIME)
        )
        try:
            while True:
                wake.append(self._tick_or_cancel())
                ticked = bool(await wake[-1])
                wake.clear()
                ended = self._follow_tick(handle, goal, result, ticked)
                if ended is not None:
                    return ended
        finally:
            self.destroy_timer(poll)

    def _tick_or_cancel(self) -> Future:
        """Return a future done with True after the next tick or on deactivation; a cancel poll sets False."""
        wake = Future()
        self.next_tick().add_done_callback(lambda _: wake.done() or wake.set_result(True))
        return wake

    def _follow_tick(
        self, handle: ServerGoalHandle, goal: _PathGoal, result: FollowPath.Result, ticked: bool = True
    ) -> FollowPath.Result | None:
        """After a tick, deactivation or a cancel request: end the goal with its outcome, or go on.

        Feedback goes out on ticks only (``ticked``), every ceil(publish_rate / feedback_rate) of them.
        """
        table = self.table
        if not self.active or table is None:
            if table is not None:
                table.halt()  # the goal ends with the device's activity: nothing moves on a later activate
            state = self.state().name
            return self._finish(
                handle,
                result,
                FollowPath.Result.FAULT,
                f"device {state} mid-goal (deactivated): the table stopped where it was; the rest of the "
                f"path is dropped",
                fault_text=f"device {state}",
            )
        fault = self.stopping_fault()
        if fault is not None:
            code, text = fault
            outcome = (
                FollowPath.Result.STALLED
                if code == DeviceStatus.FAULT_AXIS_STALL
                else FollowPath.Result.FAULT
            )
            table.halt()
            return self._finish(handle, result, outcome, text, code, text)
        if self.stopped:
            table.halt()
            return self._finish(
                handle, result, FollowPath.Result.FAULT, "stopped by ~/stop: the table halted where it was"
            )
        goal.ticks += int(ticked)
        if handle.is_cancel_requested and goal.stop_sample < 0 and table.moving:
            stop = goal.planned.cancel_stop(table.joints, table.remaining, lambda j: self._certified(goal, j))
            table.truncate(stop.keep)
            goal.stop_sample, goal.stop_certified = stop.sample, stop.certified
            goal.dropped = len(goal.planned.samples) - 1 - stop.sample
        if table.moving:
            goal.progress = goal.planned.progress(table.joints, table.remaining + goal.dropped)
            every = max(1, math.ceil(float(self.p["publish_rate"]) / float(self.p["feedback_rate"]) - 1e-9))
            if ticked and goal.ticks % every == 0:
                self._send_feedback(handle, goal)
            return None
        return self._follow_ended(handle, goal, result)

    def _follow_ended(
        self, handle: ServerGoalHandle, goal: _PathGoal, result: FollowPath.Result
    ) -> FollowPath.Result:
        """End a goal whose table stopped with no fault in force: at the end, the cancel's stop, or short."""
        table = self.table
        assert table is not None
        path = goal.planned.path
        n = len(goal.planned.samples)
        if self.count["stalls"] > goal.stalls_at_start:  # stalled, and the fault cleared before this tick
            return self._finish(
                handle,
                result,
                FollowPath.Result.STALLED,
                "an axis stalled (the fault was cleared since): the table stopped short of the path's end",
                DeviceStatus.FAULT_AXIS_STALL,
            )
        if goal.stop_sample >= 0 or handle.is_cancel_requested:
            stop = goal.stop_sample if goal.stop_sample >= 0 else n - 1
            goal.progress = float(path.times[stop] / path.duration) if path.duration > 0 else 1.0
            self._send_feedback(handle, goal)
            certified = "certified stable" if goal.stop_certified else "NOT certified stable (interlock off)"
            return self._finish(
                handle,
                result,
                FollowPath.Result.CANCELED,
                f"canceled: stopped at path sample {stop} of {n}, {certified}",
            )
        if not np.all(np.abs(table.joints - path.joints[-1]) <= ON_SAMPLE):
            return self._finish(
                handle,
                result,
                FollowPath.Result.FAULT,
                "the table halted short of the path's end (stopped and reset since)",
            )
        goal.progress = 1.0
        self._send_feedback(handle, goal)
        self.count["path_goals_reached"] += 1
        message = f"reached the last of {goal.waypoints.describe()} ({n} path samples, {path.duration:.6g} s)"
        if goal.warning:
            message += f"; {goal.warning}"
        return self._finish(handle, result, FollowPath.Result.REACHED, message)

    def _certified(self, goal: _PathGoal, sample: int) -> bool:
        """Whether the LP certifies a sample of the goal's path stable (asked only past the first failure)."""
        if goal.verdict.stable or sample < goal.verdict.first_unstable:
            return True
        assert self.prepared is not None
        return bool(self.prepared.check(goal.planned.samples[sample]).stable)

    def _send_feedback(self, handle: ServerGoalHandle, goal: _PathGoal) -> None:
        """Publish progress, gravity as the encoders read it, and the last tick's stability verdict."""
        stable, margin = self.last_stability
        handle.publish_feedback(
            FollowPath.Feedback(
                progress=goal.progress, gravity=vec(gravity_of(self._reading())), stable=stable, margin=margin
            )
        )

    def _reading(self) -> np.ndarray:
        """Return the last tick's encoder reading (the table's before the first tick)."""
        if self.last_reading is not None:
            return self.last_reading
        assert self.table is not None
        return self.table.reading()

    def _finish(
        self,
        handle: ServerGoalHandle,
        result: FollowPath.Result,
        outcome: int,
        message: str,
        fault_code: int = 0,
        fault_text: str = "",
    ) -> FollowPath.Result:
        """Fill the result (where the table is, as the encoders read it), end the goal, log the outcome."""
        result.outcome = outcome
        result.outcome_name = OUTCOME_NAMES[outcome]
        result.message = message
        result.fault_code = fault_code
        result.fault_text = fault_text
        if self.table is not None:
            reading = self._reading()
            result.tilt = [float(a) for a in reading]
            result.gravity = vec(gravity_of(reading))
        if not handle.is_active:
            pass  # already ended (a failure after its end): the result stands as sent
        elif outcome == FollowPath.Result.REACHED:
            handle.succeed()
        elif outcome == FollowPath.Result.CANCELED:
            handle.canceled()
        else:
            handle.abort()
        # Two call sites: rclpy refuses one call site logging at two severities.
        if outcome == FollowPath.Result.REACHED:
            self.get_logger().info(f"{FOLLOW_PATH} {result.outcome_name}: {message}")
        else:
            self.get_logger().warning(f"{FOLLOW_PATH} {result.outcome_name}: {message}")
        return result

    # --- time and the streams ------------------------------------------------------------------------
    def _max_advance(self) -> float:
        """Return the most simulated time (s) one tick may advance."""
        cap = float(self.p["max_advance_per_tick"])
        if cap > 0:
            return cap
        return CATCH_UP_PERIODS * max(1.0, float(self.p["real_time_factor"])) / float(self.p["publish_rate"])

    def _advance_to(self, now_ns: int) -> None:
        """Advance the table by the node-clock time since the last advance (capped); report a stall."""
        table = self.table
        if table is None or not self.active:
            return
        if self.last_tick_ns <= 0:  # activated before the node clock started: from its first reading
            self.last_tick_ns = self.clock_origin_ns() or now_ns
        elapsed = max(0, now_ns - self.last_tick_ns) / NANOSECONDS  # a clock set back simulates nothing
        self.last_tick_ns = now_ns
        cap = self._max_advance()
        if elapsed > cap:
            self.count["capped_ticks"] += 1
            elapsed = cap
        was_moving = table.moving
        stall = table.advance(elapsed)
        if stall is not None:
            self.count["stalls"] += 1
            self.raise_model_fault(DeviceStatus.FAULT_AXIS_STALL, stall.describe())
        elif was_moving and not table.moving:
            if self.goal is None:  # a goal's end is counted by the goal (path_goals_reached)
                self.count["moves_completed"] += 1
            self.publish_status()

    def tick(self) -> None:
        """Advance the table and publish joint states and gravity (as the encoders read) and stability."""
        table, prepared = self.table, self.prepared
        if table is None or prepared is None or not self.active:
            return
        now = self.get_clock().now().nanoseconds
        if not self.tick_due(now):
            return
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
        # Last: a goal waiting in next_tick resumes after this and reads what this tick published.
        self.record_tick(table.time)

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


def main(args: list[str] | None = None) -> None:
    """Run the node until shutdown."""
    run_node(AssemblyFixture, NODE_NAME, args)


if __name__ == "__main__":
    main()
