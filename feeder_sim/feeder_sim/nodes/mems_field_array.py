"""ROS 2 node: the simulated MEMS field array, a managed device (thin adapter around feeder_sim.mems).

An adapter (docs/devices.md): the station ``feeder_sim.mems.station`` holds what a tick and a program
goal do to the scene (the same station the ROS-free cell loop ticks); model ``feeder_sim.mems``
(``configure``, ``placing``, ``program_goal``, ``faults``; parameters, counters and fault specs beside
them), messages ``node_kit.msg_mems``, part services ``node_kit.mems_parts``; the device kit owns
lifecycle, tick, streams and goal runner; the node publishes and counts what the station reports. Time
(whole ``time_step`` steps per tick, at most ``max_steps_per_tick``, the rest dropped and counted), the
stiff-step warning and parts at runtime: docs/mems.md, "Time" and "Parts at runtime".
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseArray
from rclpy.action.server import ServerGoalHandle

from feeder_device.declarations import ActiveFault, Counters, DeviceError
from feeder_device.device import ManagedDevice, device_parameter_specs
from feeder_device.goals import serve_goal
from feeder_msgs.action import RunProgram
from feeder_msgs.msg import DeviceStatus, FieldProgram, MemsCellForces, MemsParts, MemsPartStates
from feeder_msgs.srv import FieldSetProgram, MemsPlaceParts, MemsRemovePart, MemsSpawnPart
from feeder_planner.errors import InputError
from feeder_planner.mems import Field, ProgramStep
from feeder_planner.node_kit import LATCHED, STREAM_DEPTH, run_node, service_guard
from feeder_planner.node_kit.msg_fields import program_from_msg
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import VIZ_PARAMETERS, DeviceViz, Drawing
from feeder_sim.mems import Grid, Scene
from feeder_sim.mems.counters import COUNTERS
from feeder_sim.mems.drawing import ArrayDrawing
from feeder_sim.mems.fault_specs import fault_specs
from feeder_sim.mems.faults import ArrayFaults
from feeder_sim.mems.parameters import BASE_FRAME, MemsParameters
from feeder_sim.mems.settling import Predictions, check_timeout, holding_step, settling_criterion
from feeder_sim.mems.spawning import ArrayParts
from feeder_sim.mems.station import MemsStation
from feeder_sim.node_kit.mems_parts import ArrayPartServices
from feeder_sim.node_kit.msg_mems import (
    RunProgramGoal,
    cell_forces_msg,
    field_program_msg,
    part_states_msgs,
    parts_msg,
)

__all__ = ["PARAMETERS", "FAULTS", "MemsFieldArrayNode", "main"]

NODE_NAME = "mems_field_array"
PARAMETERS = device_parameter_specs(MemsParameters, VIZ_PARAMETERS)

# The kit's specs of the array's faults (mems/fault_specs.py) with their DeviceStatus codes.
FAULTS = fault_specs({"power_loss": DeviceStatus.FAULT_POWER_LOSS})


class MemsFieldArrayNode(ManagedDevice[MemsParameters]):
    """Publishes ~/part_states, ~/part_poses at publish_rate and ~/field_program, ~/cell_forces, ~/parts.

    Serves ~/set_program, ~/place_parts, ~/spawn_part and ~/remove_part (refused unless the device is
    ready), the action ~/run_program, plus the device services of ``ManagedDevice`` (~/stop, ~/reset,
    ~/inject_fault; ~/status, /diagnostics).
    """

    FAULTS = FAULTS
    COUNTERS = COUNTERS

    def __init__(self) -> None:
        super().__init__(NODE_NAME, MemsParameters, VIZ_PARAMETERS, rate=20.0)
        self._forget()
        serve(self, FieldSetProgram, "~/set_program", service_guard(self)(self._on_set_program))
        parts = ArrayPartServices(self)
        serve(self, MemsPlaceParts, "~/place_parts", service_guard(self)(parts.on_place_parts))
        serve(self, MemsSpawnPart, "~/spawn_part", service_guard(self)(parts.on_spawn_part))
        serve(self, MemsRemovePart, "~/remove_part", service_guard(self)(parts.on_remove_part))
        serve_goal(self, RunProgram, "~/run_program", self._validate_run_program, self._start_run_program)
        self.viz = DeviceViz(self, self.drawing)

    def _forget(self) -> None:
        """Forget the scene and what was last published (the kit destroys the streams, resets counters)."""
        self.station: MemsStation | None = None
        self.scene: Scene | None = None
        self.array_parts: ArrayParts | None = None
        self.frame_id = ""
        self.last_cells: tuple[Field, ArrayFaults] | None = None
        self.last_grid_forces = np.zeros((0, 0, 2))
        self.array_drawing = ArrayDrawing()
        self.last_activity: tuple[bool, int, bool, bool] | None = None
        self.program_stamp = 0
        self.predictions = Predictions()

    # --- configure / activate / cleanup -----------------------------------------------------------
    def configure_device(self, p: MemsParameters) -> None:
        """Build the scene from the parameters (InputError names the field), then its streams."""
        self._forget()
        self.station = MemsStation(p)
        self.scene, self.array_parts = self.station.scene, self.station.parts
        self.frame_id = p.frame_id or self.frame(BASE_FRAME)
        self.expect_rate(p.publish_rate)
        self.program_pub = self.stream(FieldProgram, "~/field_program", LATCHED, lifecycle=False)
        self.cells_pub = self.stream(MemsCellForces, "~/cell_forces", LATCHED, lifecycle=False)
        self.parts_pub = self.stream(MemsParts, "~/parts", LATCHED, lifecycle=False)
        self.state_pub = self.stream(MemsPartStates, "~/part_states", STREAM_DEPTH)
        self.pose_pub = self.stream(PoseArray, "~/part_poses", STREAM_DEPTH)
        self.publish_parts()
        self.program_stamp = self.get_clock().now().nanoseconds
        self.publish_program()
        self.publish_cells()

    def activate_device(self) -> None:
        """Start the physics from now: the paused time is not simulated."""
        if self.station is not None:
            self.station.owed_ns = 0
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
        if self.scene is None or self.station is None:
            return
        try:
            if name == "damping":
                self.scene.set_damping(float(p.damping))
            elif name == "friction":
                self.scene.set_friction(float(p.friction))
        except InputError as error:
            raise InputError(f"parameter {name}", error.problem) from None
        self.station.p = p  # max_steps_per_tick is read from it at every tick

    def busy(self) -> bool:
        """Whether a ~/run_program goal executes, a program is before its last step or a part moves."""
        if super().busy():
            return True
        return self.station is not None and self.station.moving()

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
        why = self.station.stiffness() if self.station is not None else ""
        return (DeviceStatus.FAULT_TIME_STEP, why) if why else None

    def stop_device(self) -> None:
        """Switch every cell off: parts come to rest where they are; commands are refused until ~/reset."""
        if self.station is not None:
            self.station.stop()
            self.publish_cells()

    def reset_device(self) -> None:
        """Switch the cells back on and restart the present program from its first step."""
        if self.station is not None:
            self.station.reset()
            self.program_stamp = self.get_clock().now().nanoseconds
            self.publish_program()
            self.publish_cells()

    def apply_fault(self, fault: ActiveFault) -> None:
        """Put an injected fault into the force model (validated there: InputError naming the field)."""
        if self.station is None:
            return
        self.station.apply_fault(fault)
        self.publish_cells()

    def clear_fault(self, name: str) -> None:
        """Take an injected fault out of the force model."""
        if self.station is not None:
            self.station.clear_fault(name)
            self.publish_cells()

    # --- publishing ---------------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        """The names of the parts on the array, in the order of the scene's bodies."""
        return self.array_parts.names if self.array_parts is not None else []

    def publish_parts(self) -> None:
        """Publish the parts on the array (latched), in the order of ~/part_states."""
        if self.array_parts is not None:
            self.parts_pub.publish(parts_msg(self.array_parts.documents()))

    def publish_program(self) -> None:
        """Publish the scene's field program (latched), stamped with its node-clock start time."""
        if self.scene is None:
            return
        self.program_pub.publish(field_program_msg(self.scene.program, self.program_stamp, self.frame_id))

    def publish_cells(self, now_ns: int | None = None) -> None:
        """Publish what the cells push with (latched) when it changed: field, faults or switched off.

        Stamped at the tick's instant ``now_ns`` from the tick, at the node clock's now from a handler.
        """
        scene = self.scene
        if scene is None:
            return
        field: Field = scene.output_field()
        key = (field, scene.faults)
        if key == self.last_cells:
            return
        self.last_cells = key
        nx, ny = self.p.array_size
        self.last_grid_forces = forces = scene.cell_forces(field, Grid(nx, ny, self.p.pitch))
        if now_ns is None:
            now_ns = self.get_clock().now().nanoseconds
        self.cells_pub.publish(cell_forces_msg((nx, ny), self.p.pitch, forces, now_ns, self.frame_id))

    def drawing(self) -> Drawing | None:
        """Return what ~/markers shows: the array and the force vectors (static), the parts at their poses."""
        scene = self.scene
        if scene is None:
            return None
        nx, ny = self.p.array_size
        layout = (nx, ny, self.p.pitch, int(self.p.marker_force_stride))
        static, parts = self.array_drawing.shapes(scene, self.last_grid_forces, layout)
        return Drawing(self.frame_id, self.frame_id, static=static, dynamic=parts)

    def tick(self, now_ns: int) -> float:
        """Tick the station by the node-clock time since the last tick (capped) and publish the states."""
        station, scene = self.station, self.scene
        assert station is not None and scene is not None  # active implies configured
        ticked = station.tick(self.elapsed_ns(now_ns))
        if ticked.dropped:
            self.count.add("steps_dropped", ticked.dropped)
        self.count.add("steps", ticked.steps)
        self.publish_cells(now_ns)
        states, poses = part_states_msgs(self.names, scene.bodies, now_ns, self.frame_id)
        self.state_pub.publish(states)
        self.pose_pub.publish(poses)
        # What a controller sees change between heartbeats: busy, parts at rest, falling behind, a step
        # too stiff (the counters alone go out with the 1 Hz heartbeat rather than at every tick). Behind
        # as the status says it (never in lockstep): the monitor's wall-clock figure would make a loaded
        # host publish a status the quiet one does not.
        behind = self.is_behind(self.rate_report())
        activity = (self.busy(), sum(scene.settled()), behind, scene.stiff_since_mark > 0)
        if activity != self.last_activity:
            self.last_activity = activity
            self.publish_status()
        return scene.time

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
        assert self.station is not None  # ready implies configured
        self.station.install(program)
        self._announce_program(self.get_clock().now().nanoseconds)

    def _announce_program(self, start_ns: int) -> None:
        """Publish the program started at ``start_ns`` (latched, stamped with its start) and the forces."""
        self.program_stamp = start_ns
        self.publish_program()
        self.publish_cells()

    def goal_executing(self) -> bool:
        """Whether a ~/run_program goal executes (the part services refuse most changes then)."""
        return bool(self.goals)

    def parts_changed(self) -> None:
        """After a spawn, a removal or a reset that changed the parts: forget per-index work, republish."""
        self.predictions.clear()
        self.publish_parts()

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
        station = self.station
        assert station is not None  # accepted goals are on a ready, so configured, device
        start_ns = self.get_clock().now().nanoseconds
        machine = station.start_program(program, criterion, timeout, start_ns)
        self._announce_program(start_ns)
        self.count.add("program_goals")
        field = program[holding_step(program)].field
        predictions = self.predictions.of([body.part for body in station.scene.bodies], field)
        return RunProgramGoal(self, machine, predictions)


NODE = MemsFieldArrayNode  # what the cell host builds (feeder_cell.host)


def main(args: list[str] | None = None) -> None:
    """Run the node until shut down."""
    run_node(MemsFieldArrayNode, NODE_NAME, args)


if __name__ == "__main__":
    main()
