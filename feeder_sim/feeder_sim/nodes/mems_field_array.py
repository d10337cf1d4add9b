"""ROS 2 node: the simulated MEMS field array, a managed device (thin adapter around feeder_sim.mems).

An adapter (docs/devices.md): the model is ``feeder_sim.mems`` (the scene built by ``configure``, placing
by ``placing``, the run-program goal of ``program_goal``), the parameters ``mems.parameters``, the
counters ``mems.counters``; the device kit (``feeder_device``) owns the lifecycle, the tick, the streams
and the goal runner.

Lifecycle: configure loads the part and program files and builds the scene (a bad file or parameter
fails the transition, naming it); activate starts the physics timer and the part-state streams;
deactivate freezes the physics where it is (the latched descriptions stay); cleanup releases the scene.

Time: everything is on the node clock (``use_sim_time`` puts it on the cell clock). At every tick of
``publish_rate`` (Hz of the node clock) the scene advances by the node-clock time elapsed since the last
tick, in whole ``time_step`` steps (the remainder carries to the next tick), but by at most
``max_steps_per_tick`` steps: what that cap leaves unsimulated is dropped and counted
(``steps_dropped``), so a device that cannot keep up lags visibly (its simulated time, recorded at every
tick, falls behind the clock) and never silently runs slower.

The ideal model measures how stiff each step is (``feeder_sim.mems.tolerances.STIFF_STEP_RATIO``): while
the present program or drag has had steps beyond that margin, status and diagnostics warn with
FAULT_TIME_STEP (not a stop; counter ``stiff_steps``), and a ``~/run_program`` goal whose parts come to
rest ends FAULT with that code rather than SETTLED: a too-large step can stop a part off its equilibrium.

Injected faults (``~/inject_fault`` or the ``inject_faults`` parameter) act through the force model
(``feeder_sim.mems.faults``); this node only wires them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray
from rclpy.action.server import ServerGoalHandle
from rclpy.time import Time as RclTime

from feeder_device.declarations import ActiveFault, Counters, DeviceError, FaultSpec
from feeder_device.device import ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import RunProgram
from feeder_msgs.msg import (
    DeviceStatus,
    FieldProgram,
    FieldSpec,
    MemsCellForces,
    MemsParts,
    MemsPartState,
    MemsPartStates,
)
from feeder_msgs.srv import FieldSetProgram, MemsPlaceParts
from feeder_planner.drawing import Shape, triangulate_loops
from feeder_planner.errors import InputError
from feeder_planner.mems import Field, ProgramStep
from feeder_planner.node_kit import LATCHED, STREAM_DEPTH, planar_pose, run_node, service_guard
from feeder_planner.node_kit.msg_fields import fill_field_spec, program_from_msg
from feeder_planner.node_kit.msg_parts import part_to_msg
from feeder_planner.node_kit.request_limits import MAX_NAMES, check_count
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import VIZ_PARAMETERS, DeviceViz, Drawing
from feeder_sim.mems import Grid, Scene
from feeder_sim.mems.configure import configure_scene
from feeder_sim.mems.counters import COUNTERS
from feeder_sim.mems.drawing import array_shapes, force_shapes, parts_shapes
from feeder_sim.mems.faults import ArrayFaults
from feeder_sim.mems.parameters import AUTO_CATCH_UP_TICKS, BASE_FRAME, NANOSECONDS, MemsParameters
from feeder_sim.mems.placing import place_parts, placement_reach, reset_parts
from feeder_sim.mems.program_goal import ProgramGoal
from feeder_sim.mems.settling import (
    Match,
    Prediction,
    check_timeout,
    holding_start,
    holding_step,
    match,
    predict,
    settling_criterion,
)
from feeder_sim.mems.tolerances import STIFF_STEP_RATIO

__all__ = ["PARAMETERS", "FAULTS", "MemsFieldArrayNode", "main"]

NODE_NAME = "mems_field_array"
PARAMETERS = device_parameter_specs(MemsParameters, VIZ_PARAMETERS)

FAULTS = {
    "dead_cells": FaultSpec(
        "dead_cells",
        "cells that push with no force (array fidelity)",
        "fraction of the cells in (0, 1], drawn with the seed; or explicit indices (i * ny + j)",
        indices_label="cells",
    ),
    "stuck_cells": FaultSpec(
        "stuck_cells",
        "cells stuck pushing in direction angle (rad) at the field's magnitude (array fidelity)",
        "fraction of the cells in (0, 1], drawn with the seed; or explicit indices; angle: the direction",
        indices_label="cells",
    ),
    "field_strength_error": FaultSpec(
        "field_strength_error",
        "every cell force scaled by 1 + e",
        "relative error e (> -1, nonzero)",
    ),
    "power_loss": FaultSpec(
        "power_loss",
        "the array has lost power: no field at all",
        stops_device=True,
        code=DeviceStatus.FAULT_POWER_LOSS,
    ),
}


# The array's static drawing, rebuilt on change: (cell forces drawn, (nx, ny, pitch, stride) or () before
# the first, shapes).
ArrayDrawing = tuple[np.ndarray | None, tuple[int, int, float, int] | tuple[()], list[Shape]]


def _stamp(nanoseconds: int) -> Time:
    """Return a node-clock time (integer ns) as a message stamp."""
    return RclTime(nanoseconds=nanoseconds).to_msg()


class MemsFieldArrayNode(ManagedDevice[MemsParameters]):
    """Publishes ~/part_states, ~/part_poses at publish_rate and ~/field_program, ~/cell_forces, ~/parts.

    Serves ~/set_program and ~/place_parts (refused unless the device is ready), the action
    ~/run_program, plus the device services of ``ManagedDevice`` (~/stop, ~/reset, ~/inject_fault;
    ~/status, /diagnostics).
    """

    FAULTS = FAULTS
    COUNTERS = COUNTERS

    def __init__(self) -> None:
        super().__init__(NODE_NAME, MemsParameters, VIZ_PARAMETERS, rate=20.0)
        self._forget()
        serve(self, FieldSetProgram, "~/set_program", service_guard(self)(self._on_set_program))
        serve(self, MemsPlaceParts, "~/place_parts", service_guard(self)(self._on_place_parts))
        serve_goal(self, RunProgram, "~/run_program", self._validate_run_program, self._start_run_program)
        self.viz = DeviceViz(self, self.drawing)

    def _forget(self) -> None:
        """Forget the scene and what was last published (the kit destroys the streams, resets counters)."""
        self.scene: Scene | None = None
        self.names: list[str] = []
        self.initial = np.zeros((0, 3))
        self.frame_id = ""
        self.step_ns = 1
        self.owed_ns = 0
        self.last_cells: tuple[Field, ArrayFaults] | None = None
        self.last_grid_forces = np.zeros((0, 0, 2))
        self.part_triangles: tuple[Scene | None, list[np.ndarray]] = (None, [])
        self.array_drawing: ArrayDrawing = (None, (), [])
        self.last_activity: tuple[bool, int, bool, bool] | None = None
        self.program_stamp = 0
        self.predictions: dict[tuple[int, Field], Prediction] = {}

    # --- configure / activate / cleanup -----------------------------------------------------------
    def configure_device(self, p: MemsParameters) -> None:
        """Build the scene from the parameters (InputError names the field), then its streams."""
        self._forget()
        configured = configure_scene(p)
        self.scene, self.names, self.initial = configured.scene, configured.names, configured.initial
        self.frame_id = p.frame_id or self.frame(BASE_FRAME)
        self.step_ns = int(round(p.time_step * NANOSECONDS))
        self.expect_rate(p.publish_rate)
        self.program_pub = self.stream(FieldProgram, "~/field_program", LATCHED, lifecycle=False)
        self.cells_pub = self.stream(MemsCellForces, "~/cell_forces", LATCHED, lifecycle=False)
        self.parts_pub = self.stream(MemsParts, "~/parts", LATCHED, lifecycle=False)
        self.state_pub = self.stream(MemsPartStates, "~/part_states", STREAM_DEPTH)
        self.pose_pub = self.stream(PoseArray, "~/part_poses", STREAM_DEPTH)
        self.parts_pub.publish(MemsParts(parts=[part_to_msg(d) for d in configured.documents]))
        self.program_stamp = self.get_clock().now().nanoseconds
        self.publish_program()
        self.publish_cells()

    def activate_device(self) -> None:
        """Start the physics from now: the paused time is not simulated."""
        self.owed_ns = 0
        self.last_activity = None
        now = self.get_clock().now().nanoseconds
        if self.program_stamp <= 0 < now:  # configured before the (sim) clock had started
            self.program_stamp = now
            self.publish_program()

    def cleanup_device(self) -> None:
        """Release the scene."""
        self._forget()

    # --- runtime parameters, status, stop/reset ----------------------------------------------------
    def apply_parameter(self, name: str, p: MemsParameters) -> None:
        """Apply damping, friction or max_steps_per_tick to the running scene (the others are read-only)."""
        if self.scene is None:
            return
        try:
            if name == "damping":
                self.scene.set_damping(float(p.damping))
            elif name == "friction":
                self.scene.set_friction(float(p.friction))
        except InputError as error:
            raise InputError(f"parameter {name}", error.problem) from None
        # max_steps_per_tick is read from self.p at every tick, which the kit updates after this returns

    def busy(self) -> bool:
        """Whether a ~/run_program goal executes, a program is before its last step or a part moves."""
        if super().busy():
            return True
        if self.scene is None or not self.scene.switched_on or self.scene.faults.power_loss:
            return False
        return not self.scene.on_last_step() or not all(self.scene.settled())

    def counters(self) -> Counters:
        """Return the counts, with the parts at rest and the stiff steps read off the scene."""
        if self.scene is not None:
            self.count.set("parts_settled", sum(self.scene.settled()))
            self.count.set("stiff_steps", self.scene.stiff_steps)
        return self.count

    def warning_fault(self) -> tuple[int, str] | None:
        """Return an injected non-stopping fault, else FAULT_TIME_STEP while the step is too stiff."""
        return super().warning_fault() or self.time_step_warning()

    def time_step_warning(self) -> tuple[int, str] | None:
        """Return (FAULT_TIME_STEP, why) when the present program or drag has had stiff ideal steps."""
        scene = self.scene
        if scene is None or scene.stiff_since_mark == 0:
            return None
        dt = float(self.p.time_step)
        return DeviceStatus.FAULT_TIME_STEP, (
            f"time_step {dt:g} s is beyond the ideal model's stability margin at damping {scene.damping:g}: "
            f"{scene.stiff_since_mark} steps changed a part's velocity by up to {scene.peak_step_ratio:.2f} "
            f"times itself (margin {STIFF_STEP_RATIO:g}; from 2 a part can stop off its equilibrium), so "
            f"poses are not certified; a time_step of {scene.stable_step_estimate(dt):.2g} s or less, or "
            "more damping, keeps the margin"
        )

    def stop_device(self) -> None:
        """Switch every cell off: parts come to rest where they are; commands are refused until ~/reset."""
        if self.scene is not None:
            self.scene.switched_on = False
            self.publish_cells()

    def reset_device(self) -> None:
        """Switch the cells back on and restart the present program from its first step."""
        if self.scene is not None:
            self.scene.switched_on = True
            self.scene.set_program(self.scene.program)
            self.program_stamp = self.get_clock().now().nanoseconds
            self.publish_program()
            self.publish_cells()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the force model (validated there: InputError naming the field)."""
        if self.scene is None:
            return
        nx, ny = self.p.array_size
        faults = self.scene.faults.with_fault(
            fault.spec.name,
            value=fault.value,
            indices=fault.indices,
            angle=fault.angle,
            seed=fault.seed,
            cells=(nx, ny),
            fidelity=self.scene.fidelity,
        )
        self.scene.set_faults(faults)
        self.publish_cells()

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the force model."""
        if self.scene is not None:
            self.scene.set_faults(self.scene.faults.without(name))
            self.publish_cells()

    # --- publishing ---------------------------------------------------------------------------------
    def publish_program(self) -> None:
        """Publish the scene's field program (latched), stamped with its node-clock start time."""
        if self.scene is None:
            return
        msg = FieldProgram(
            name="program", steps=[fill_field_spec(FieldSpec(), s) for s in self.scene.program]
        )
        msg.header.frame_id = self.frame_id
        msg.header.stamp = _stamp(self.program_stamp)
        self.program_pub.publish(msg)

    def publish_cells(self) -> None:
        """Publish what the cells push with (latched) when it changed: field, faults or switched off."""
        scene = self.scene
        if scene is None:
            return
        field: Field = scene.output_field()
        key = (field, scene.faults)
        if key == self.last_cells:
            return
        self.last_cells = key
        nx, ny = self.p.array_size
        pitch = self.p.pitch
        grid_forces = scene.forces.cell_forces(field)
        if grid_forces is None:  # ideal / dynamic: the ideal field sampled at the cell centres
            grid_forces = scene.faults.apply_to_cells(field.force_density(Grid(nx, ny, pitch).centers()))
        self.last_grid_forces = grid_forces
        msg = MemsCellForces(
            nx=nx,
            ny=ny,
            pitch=pitch,
            fx=grid_forces[..., 0].ravel().tolist(),
            fy=grid_forces[..., 1].ravel().tolist(),
        )
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self.frame_id
        self.cells_pub.publish(msg)

    def drawing(self) -> Drawing | None:
        """Return what ~/markers shows: the array and the force vectors (static), the parts at their poses."""
        scene = self.scene
        if scene is None:
            return None
        if self.part_triangles[0] is not scene:  # triangulated once per scene, placed at every update
            self.part_triangles = (scene, [triangulate_loops(b.part.loops()) for b in scene.bodies])
        nx, ny = self.p.array_size
        layout = (nx, ny, self.p.pitch, int(self.p.marker_force_stride))
        # The array and its force arrows change only with the cells' forces (a new array from publish_cells)
        # or the layout: built then, not at every update (thousands of arrows on a large array).
        forces, (drawn, drawn_layout, static) = self.last_grid_forces, self.array_drawing
        if drawn is not forces or drawn_layout != layout:
            grid = Grid(nx, ny, layout[2])
            static = array_shapes(grid) + force_shapes(grid, forces, layout[3])
            self.array_drawing = (forces, layout, static)
        parts = parts_shapes(
            [b.part for b in scene.bodies], [b.pose for b in scene.bodies], self.part_triangles[1]
        )
        return Drawing(self.frame_id, self.frame_id, static=static, dynamic=parts)

    def _max_steps(self) -> int:
        """Return the cap on steps per tick (max_steps_per_tick, or the automatic one for 0)."""
        cap = int(self.p.max_steps_per_tick)
        if cap > 0:
            return cap
        factor = max(1.0, float(self.p.real_time_factor))
        period_ns = NANOSECONDS * factor / float(self.p.publish_rate)
        return max(1, math.ceil(AUTO_CATCH_UP_TICKS * period_ns / self.step_ns))

    def tick(self, now_ns: int) -> float:
        """Advance the scene by the node-clock time since the last tick (capped) and publish the states."""
        scene = self.scene
        assert scene is not None  # active implies configured
        self.owed_ns += self.elapsed_ns(now_ns)
        steps, self.owed_ns = divmod(self.owed_ns, self.step_ns)
        cap = self._max_steps()
        if steps > cap:
            self.count.add("steps_dropped", steps - cap)
            steps = cap
        dt = float(self.p.time_step)
        for _ in range(steps):
            scene.step(dt)
        self.count.add("steps", steps)
        self.publish_cells()
        states = MemsPartStates(parts=self.part_states())
        states.header.stamp = _stamp(now_ns)
        states.header.frame_id = self.frame_id
        poses = PoseArray(poses=[state.pose for state in states.parts])
        poses.header = states.header
        self.state_pub.publish(states)
        self.pose_pub.publish(poses)
        # What a controller sees change between heartbeats: busy, parts at rest, falling behind, a step
        # too stiff (the counters alone go out with the 1 Hz heartbeat rather than at every tick).
        activity = (self.busy(), sum(scene.settled()), self.rate_report().behind, scene.stiff_since_mark > 0)
        if activity != self.last_activity:
            self.last_activity = activity
            self.publish_status()
        return scene.time

    def part_states(self, scene: Scene | None = None, names: list[str] | None = None) -> list[MemsPartState]:
        """Return every part's state now: pose, twist, field wrench (of the node's scene by default).

        A goal passes the scene and names it started with: a cleanup may have released the node's.
        """
        scene = scene or self.scene
        names = self.names if names is None else names
        states = []
        for name, body in zip(names, scene.bodies if scene else [], strict=True):
            state = MemsPartState(name=name, theta=float(body.pose[2]))
            state.pose = self._pose(body.pose)
            state.twist.linear.x, state.twist.linear.y = float(body.velocity[0]), float(body.velocity[1])
            state.twist.angular.z = float(body.velocity[2])
            state.wrench.force.x, state.wrench.force.y = float(body.wrench[0]), float(body.wrench[1])
            state.wrench.torque.z = float(body.wrench[2])
            states.append(state)
        return states

    @staticmethod
    def _pose(pose: np.ndarray) -> Pose:
        """Return a pose (x, y, theta) as a Pose message."""
        return planar_pose(pose[0], pose[1], pose[2])

    # --- device services ----------------------------------------------------------------------------
    def _on_set_program(
        self, request: FieldSetProgram.Request, response: FieldSetProgram.Response
    ) -> FieldSetProgram.Response:
        """Start the requested field program now (refused while a ~/run_program goal executes)."""
        self.require_ready("set_program")
        if self.goals:
            raise DeviceError("set_program refused: a ~/run_program goal is executing; cancel it first")
        program = program_from_msg(request.program)
        self.install_program(program)
        self.count.add("programs")
        self.publish_status()
        return response

    def install_program(self, program: tuple[ProgramStep, ...]) -> None:
        """Start ``program`` now and publish it (latched, stamped with its start) and the cells' forces."""
        assert self.scene is not None  # ready implies configured
        self.scene.set_program(program)
        self.program_stamp = self.get_clock().now().nanoseconds
        self.publish_program()
        self.publish_cells()

    def _on_place_parts(
        self, request: MemsPlaceParts.Request, response: MemsPlaceParts.Response
    ) -> MemsPlaceParts.Response:
        """Put named parts at requested poses at rest, or every part back at its initial pose."""
        self.require_ready("place_parts")
        assert self.scene is not None  # ready implies configured
        if request.reset:
            reset_parts(self.scene, self.initial)
        else:
            check_count(len(request.names), MAX_NAMES, "names", "names")
            reach = placement_reach(self.p.array_size, float(self.p.pitch))
            coordinates = (list(request.x), list(request.y), list(request.theta))
            place_parts(self.scene, self.names, (list(request.names), *coordinates), reach)
        self.count.add("placements")
        self.publish_status()
        return response

    # --- ~/run_program --------------------------------------------------------------------------------
    def _validate_run_program(self, goal: RunProgram.Goal) -> None:
        """Check a goal's fields (the kit has checked that the device is ready and free).

        The program is checked by the one validation ``~/set_program`` uses, so both refuse the same
        programs naming the same fields (``program.steps[1].delta``).
        """
        program_from_msg(goal.program)
        check_timeout(goal.timeout)
        settling_criterion(goal.tolerance, goal.dwell)

    def _start_run_program(self, handle: ServerGoalHandle) -> RunProgramGoal:
        """Install the goal's program and start following it (see RunProgram.action)."""
        goal = handle.request
        program = program_from_msg(goal.program)
        criterion = settling_criterion(goal.tolerance, goal.dwell)
        timeout = check_timeout(goal.timeout)
        scene = self.scene
        assert scene is not None  # accepted goals are on a ready, so configured, device
        self.install_program(program)
        self.count.add("program_goals")
        field = program[holding_step(program)].field
        predictions = [self.prediction(i, field) for i in range(len(scene.bodies))]
        machine = ProgramGoal(
            scene, self.names, criterion, timeout, self.program_stamp, holding_start(program)
        )
        return RunProgramGoal(self, machine, predictions)

    def prediction(self, index: int, field: Field) -> Prediction:
        """Return the planner's stable equilibria of part ``index`` in ``field`` (computed once per field)."""
        assert self.scene is not None
        key = (index, field)
        if key not in self.predictions:
            self.predictions[key] = predict(self.scene.bodies[index].part, field)
        return self.predictions[key]


class RunProgramGoal:
    """The runner's view of a ``ProgramGoal``: feedback and result as RunProgram messages."""

    def __init__(self, node: MemsFieldArrayNode, machine: ProgramGoal, predictions: list[Prediction]) -> None:
        self.node, self.machine, self.predictions = node, machine, predictions
        self.pending: list[RunProgram.Feedback] = []
        self.ended: RunProgram.Result | None = None

    @property
    def done(self) -> bool:
        """Whether the goal has ended."""
        return self.machine.done

    def advance(self, now_ns: int) -> None:
        """Decide after the tick; feedback and result are built now, from the scene this tick left."""
        node = self.node
        warning = node.time_step_warning()
        self.machine.advance(now_ns, node.stopping_fault(), node.stopped, warning)
        if self.machine.feedback_due:
            scene = self.machine.scene
            matches = [match(p, b.pose) for p, b in zip(self.predictions, scene.bodies, strict=True)]
            self.pending.append(
                RunProgram.Feedback(
                    time=self.machine.elapsed,
                    parts=node.part_states(scene, self.machine.names),
                    settled=list(self.machine.flags),
                    equilibrium_distance=[m.distance for m in matches],
                )
            )
        self._result()

    def cancel(self, reason: str) -> None:
        """End now, where the parts are (the program stays on)."""
        self.machine.cancel(reason)
        self.advance(self.node.get_clock().now().nanoseconds)

    def halt(self) -> None:
        """Nothing to stop: the program stays on, as a cancel leaves it."""

    def interrupt(self, reason: str) -> None:
        """End now: the device left active."""
        self.machine.interrupt(self.node.state().name)
        self._result()

    def feedback(self) -> Sequence[RunProgram.Feedback]:
        """Return the feedback built since the last call."""
        pending, self.pending = self.pending, []
        return pending

    def result(self) -> tuple[str, RunProgram.Result]:
        """Return the terminal state and the result built when the goal ended."""
        result = self._result()
        assert result is not None  # the runner asks only once the goal ended
        self.node.get_logger().info(f"run_program {result.outcome_name}: {result.message}")
        terminal = {"SETTLED": "succeed", "CANCELED": "canceled"}.get(result.outcome_name, "abort")
        return terminal, result

    def _result(self) -> RunProgram.Result | None:
        """Build the result once the machine ends: final states, the equilibrium each part reached."""
        outcome = self.machine.outcome
        if outcome is None or self.ended is not None:
            return self.ended
        scene, names = self.machine.scene, self.machine.names
        matches = [match(p, b.pose) for p, b in zip(self.predictions, scene.bodies, strict=True)]
        summary = [
            _equilibrium_summary(name, prediction, found)
            for name, prediction, found in zip(names, self.predictions, matches, strict=True)
        ]
        self.ended = RunProgram.Result(
            outcome=outcome.code,
            outcome_name=outcome.name,
            message="; ".join([outcome.message, *summary]),
            settled=outcome.settled,
            parts=self.node.part_states(scene, names),
            equilibrium=[m.index for m in matches],
            equilibrium_theta=[m.theta for m in matches],
            equilibrium_distance=[m.distance for m in matches],
            fault_code=int(outcome.fault[0]),
            fault_text=outcome.fault[1],
        )
        return self.ended


def _equilibrium_summary(name: str, prediction: Prediction, found: Match) -> str:
    """Say where a part ended against its prediction, for the result's message."""
    if not prediction.predicted:
        return f"{name}: {prediction.reason}"
    if found.at:
        return (
            f"{name}: at predicted equilibrium {found.index} (theta {found.theta:.6g} rad, "
            f"{found.distance:.2g} rad and {found.position_distance:.2g} m off)"
        )
    return (
        f"{name}: at no predicted equilibrium (the nearest, theta {found.theta:.6g} rad, is "
        f"{found.distance:.2g} rad and {found.position_distance:.2g} m off)"
    )


def main(args: list[str] | None = None) -> None:
    """Run the node until shut down."""
    run_node(MemsFieldArrayNode, NODE_NAME, args)


if __name__ == "__main__":
    main()
