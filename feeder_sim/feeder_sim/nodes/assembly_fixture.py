"""ROS 2 node: a two-axis tilting fixture holding an assembly, with a stability interlock (Figs. 1-2).

An adapter (docs/devices.md): the station ``feeder_sim.fixture.station`` holds what a tick and a
follow-path goal do to the table (the same station the ROS-free cell loop ticks); the model is
``feeder_sim.fixture`` (the table, its faults, the interlock, the follow-path goal of ``path_goal``), the
parameters ``fixture.parameters``, the counters ``fixture.counters``, the faults as the kit declares them
``fixture.fault_specs``, the messages ``feeder_sim.node_kit.msg_fixture``; the device kit
(``feeder_device``) owns the lifecycle, the tick, the streams and the goal runner. ``~/move`` and
``~/follow_path`` plan on one code path (``fixture.follow.plan_path``). Lifecycle, time (node clock; at
most ``max_advance_per_tick`` per tick, a longer gap counted in ``capped_ticks``) and faults:
docs/assembly.md. ``~/stability`` is the model's ground truth; the encoder faults change only what
``~/joint_states`` and ``~/gravity`` report.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.action.server import ServerGoalHandle
from sensor_msgs.msg import JointState

from feeder_device.declarations import ActiveFault, DeviceError
from feeder_device.device import ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import FollowPath
from feeder_msgs.msg import DeviceStatus, StabilityStatus
from feeder_msgs.srv import FixtureMove
from feeder_planner.assembly import PreparedAssembly
from feeder_planner.errors import FeederError
from feeder_planner.node_kit import STREAM_DEPTH, run_node, service_guard
from feeder_planner.node_kit.request_limits import MAX_MOVE_SAMPLES, check_arc_samples
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.tf import quaternion_from_matrix
from feeder_planner.node_kit.viz import VIZ_PARAMETERS, DeviceViz, Drawing, MovingFrame
from feeder_sim.fixture import (
    FAULT_INFO,
    GoalWaypoints,
    PlannedPath,
    Table,
    TableLimits,
    certify,
    check_fault_name,
    plan_goal,
    plan_path,
)
from feeder_sim.fixture.counters import COUNTERS
from feeder_sim.fixture.drawing import body_shapes, gravity_shape, table_rotation, table_shapes
from feeder_sim.fixture.fault_specs import fault_specs
from feeder_sim.fixture.interlock import InterlockRefusedError
from feeder_sim.fixture.parameters import BASE_FRAME, TABLE_BASE_FRAME, FixtureParameters, retimed_limits
from feeder_sim.fixture.path_goal import PathOutcome
from feeder_sim.fixture.station import FixtureStation
from feeder_sim.node_kit.msg_fixture import (
    FOLLOW_PATH,
    FollowPathGoal,
    fill_move_response,
    follow_path_waypoints,
    gravity_msg,
    joint_state_msg,
    move_waypoints,
    stability_msg,
)
from feeder_sim.node_kit.stamp import header

__all__ = ["PARAMETERS", "FAULTS", "AssemblyFixtureNode", "InterlockRefusedError", "main"]

NODE_NAME = "assembly_fixture"
PARAMETERS = device_parameter_specs(FixtureParameters, VIZ_PARAMETERS)

# The kit's specs of the table's faults (fixture/fault_specs.py) with their DeviceStatus codes.
FAULTS = fault_specs(
    {"axis_stall": DeviceStatus.FAULT_AXIS_STALL, "rate_limit": DeviceStatus.FAULT_RATE_LIMIT}
)


class AssemblyFixtureNode(ManagedDevice[FixtureParameters]):
    """Publishes ~/joint_states, ~/gravity, ~/stability at publish_rate; serves ~/move and ~/follow_path."""

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
        self.station: FixtureStation | None = None
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
        self.station = station = FixtureStation(p, DeviceStatus.FAULT_AXIS_STALL)
        self.table, self.prepared, self.limits = station.table, station.prepared, station.limits
        assembly = station.assembly
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

        interlock and max_advance_per_tick are read from the station's ``p`` at every move or tick, path_step
        from the node's, which the kit updates once this returns; every other parameter is read-only.
        """
        if self.station is None:
            return
        if name in ("max_rate_x", "max_rate_y"):
            limits = retimed_limits(self.limits, name, p)
            self.limits = self.station.limits = self.station.table.limits = limits
        self.station.p = p  # set once the change was accepted

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
        if self.station is None:
            return
        self._advance_to(self.get_clock().now().nanoseconds)  # a fault acts from now, not from the last tick
        self.station.apply_fault(fault)
        self.get_logger().warning(
            f"injected fault {fault.spec.name}: {self.station.table.faults.describe(fault.spec.name)}"
        )

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the table model; clearing a stall that acted ends its FAULT."""
        if self.station is not None and self.station.clear_fault(name, self.model_fault):
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
        waypoints = move_waypoints(request)
        self._advance_to(self.get_clock().now().nanoseconds)
        self.require_ready("move")  # the table may have stalled on its way here
        # Counted before sampling: every sample is an LP on this single-threaded device (request_limits).
        check_arc_samples(table.gravity(), waypoints, self.p.path_step, "waypoints", MAX_MOVE_SAMPLES)
        # Joint limits are checked before anything moves; the timing is at the rates the axes reach now.
        planned = plan_path(table, waypoints, self.p.path_step)
        verdict = certify(prepared, planned.samples)
        fill_move_response(response, planned, verdict)
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
        waypoints = follow_path_waypoints(goal, self.limits)
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
        assert self.station is not None
        started = self.station.follow(waypoints, planned)
        if started.verdict is not None and not started.verdict.stable:
            goal.unstable_at(started.verdict)
        if started.goal is None:
            assert started.early is not None
            if started.early.name == "REFUSED":
                self.count.add("path_goals_refused")
            return goal.ended_early(started.early)
        if started.warning:
            self.get_logger().warning(f"{FOLLOW_PATH}: {started.warning}")
        self.publish_status()
        return goal.following(started.goal)

    def reading(self) -> np.ndarray:
        """Return the last tick's encoder reading (the table's before the first tick)."""
        if self.last_reading is not None:
            return self.last_reading
        assert self.table is not None
        return self.table.reading()

    # --- time and the streams ------------------------------------------------------------------------
    def _advance_to(self, now_ns: int) -> None:
        """Advance the table by the node-clock time since the last advance (capped); report a stall."""
        if self.station is None or not self.active:
            return
        advanced = self.station.advance(self.elapsed_ns(now_ns))
        if advanced.capped:
            self.count.add("capped_ticks")
        if advanced.stall is not None:
            self.count.add("stalls")
            self.raise_model_fault(DeviceStatus.FAULT_AXIS_STALL, advanced.stall.describe())
        elif advanced.move_ended:
            if not self.goals:  # a goal's end is counted by the goal (path_goals_reached)
                self.count.add("moves_completed")
            self.publish_status()

    def tick(self, now_ns: int) -> float:
        """Advance the table and publish joint states and gravity (as the encoders read) and stability."""
        table, prepared = self.table, self.prepared
        assert table is not None and prepared is not None  # active implies configured
        self._advance_to(now_ns)
        head = header(now_ns, self.frame_id)
        self.last_reading = reading = table.reading()
        self.joint_pub.publish(joint_state_msg(head, reading, table.velocity))
        self.gravity_pub.publish(gravity_msg(head, reading))
        status = stability_msg(head, prepared, table.gravity(), table.moving)
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


NODE = AssemblyFixtureNode  # what the cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the node until shutdown."""
    run_node(AssemblyFixtureNode, NODE_NAME, args)


if __name__ == "__main__":
    main()
