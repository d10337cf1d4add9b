"""ROS 2 node: the simulated MEMS field array, a managed device (thin adapter around feeder_sim.mems).

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

``~/run_program`` (feeder_msgs/RunProgram) installs a field program when its goal is accepted, exactly
as ``~/set_program`` does, and follows it tick by tick until every part has settled or the timeout
(node clock) passes; when parts settled and which predicted equilibrium each reached is
``feeder_sim.mems.settling``. Feedback goes out at most every ``FEEDBACK_PERIOD`` of node clock.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from rclpy.time import Time as RclTime

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
from feeder_planner.drawing import triangulate_loops
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import DELTA_MAX, DELTA_MIN, CombinedField, Field, ProgramStep, program_from_mapping
from feeder_planner.node_kit import (
    LATCHED,
    STREAM_DEPTH,
    ParameterSpec,
    in_range,
    integer,
    integer_at_least,
    non_negative,
    one_of,
    planar_pose,
    positive,
    run_node,
    service_guard,
)
from feeder_planner.node_kit.actions import serve_device_action
from feeder_planner.node_kit.device import ActiveFault, DeviceError, FaultSpec, ManagedDevice
from feeder_planner.node_kit.msg_fields import fill_field_spec, program_from_msg
from feeder_planner.node_kit.msg_parts import part_to_msg
from feeder_planner.node_kit.request_limits import MAX_NAMES, check_count
from feeder_planner.node_kit.services import serve
from feeder_planner.node_kit.viz import VIZ_PARAMETERS, DeviceViz, Drawing
from feeder_planner.parts import Part, load_part
from feeder_sim.mems import FIDELITIES, Body, Grid, Scene, random_poses
from feeder_sim.mems.drawing import array_shapes, force_shapes, parts_shapes
from feeder_sim.mems.settling import (
    Match,
    Prediction,
    SettlingDetector,
    check_timeout,
    holding_start,
    holding_step,
    match,
    predict,
    settling_criterion,
)
from feeder_sim.mems.tolerances import (
    DEFAULT_CELLS,
    DEFAULT_DAMPING,
    DEFAULT_FRICTION,
    DEFAULT_PITCH,
    STIFF_STEP_RATIO,
)

__all__ = ["PARAMETERS", "FAULTS", "MemsFieldArray", "main"]

NODE_NAME = "mems_field_array"
BASE_FRAME = "mems_array"

# max_steps_per_tick 0 means the steps of this many periods of the node clock, times the configured
# real-time factor when it is above 1 (a fast cell clock advances in jumps of several periods): a tick
# that comes late by up to three periods (a loaded 2-core machine) still catches up in full; anything
# later is dropped and shows as steps_dropped and a lagging real-time factor.
AUTO_CATCH_UP_TICKS = 4

NANOSECONDS = 1_000_000_000

# ~/run_program feedback at most this often (s of node clock): 10 Hz, every other tick at the default
# 20 Hz, enough to follow a part without doubling the traffic of ~/part_states.
FEEDBACK_PERIOD = 0.1
# A cancel is looked at this often (Hz, steady clock) besides at every tick, so that a goal under a
# held /clock can still be cancelled: cancelling moves nothing, it needs no tick.
CANCEL_POLL_RATE = 10.0
# ~/place_parts keeps parts within this many array extents of the origin, and angles within +-MAX_PLACE_ANGLE.
PLACE_REACH_FACTOR = 10.0
MAX_PLACE_ANGLE = 1e6  # rad: far beyond any turn count, short of where float angles lose their meaning
OUTCOME_NAMES = {
    RunProgram.Result.SETTLED: "SETTLED",
    RunProgram.Result.TIMEOUT: "TIMEOUT",
    RunProgram.Result.FAULT: "FAULT",
    RunProgram.Result.CANCELED: "CANCELED",
}


def _array_size(value: Sequence[object]) -> str | None:
    """Check the array_size parameter: two integers > 0."""
    ok = len(value) == 2 and all(isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in value)
    return None if ok else f"must be two integers > 0 [nx, ny], got {list(value)!r}"


def _time_step(value: Any) -> str | None:
    """Check the time_step parameter: > 0 and at least one nanosecond (steps are counted in ns)."""
    problem = positive(value)
    if problem is None and round(value * NANOSECONDS) < 1:
        problem = f"must be at least 1e-9 s, got {value!r}"
    return problem


PARAMETERS = (
    ParameterSpec(
        "array_size",
        list(DEFAULT_CELLS),
        "number of actuator cells [nx, ny] of the array",
        _array_size,
        read_only=True,
    ),
    ParameterSpec(
        "pitch",
        DEFAULT_PITCH,
        "side of one square actuator cell (m); the array is centred on the plane origin",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "fidelity",
        "ideal",
        "force model: ideal (exact field integrals, quasi-static), array (cells at "
        "the pitch, exact covered areas), dynamic (inertia, friction, collisions)",
        one_of(FIDELITIES),
        read_only=True,
    ),
    ParameterSpec(
        "directions",
        0,
        "quantise cell forces to this many actuator directions (0: exact directions)",
        integer_at_least(0),
        read_only=True,
    ),
    ParameterSpec(
        "part_files",
        [""],
        "part files (YAML, contract section 2); empty entries are ignored",
        read_only=True,
    ),
    ParameterSpec(
        "initial_poses",
        [0.0],
        "x, y, theta (m, m, rad) per part, flattened; [] or [0.0]: random poses "
        "within placement_radius drawn with the seed",
        read_only=True,
    ),
    ParameterSpec(
        "placement_radius",
        1e-3,
        "radius (m) of the disc random initial positions are drawn in",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "program_file",
        "",
        "field program YAML ({steps: [{field: {...}, duration: s}]}, metres); "
        "empty: combined field delta = default_delta forever",
        read_only=True,
    ),
    ParameterSpec(
        "default_delta",
        0.2,
        "delta of the default combined field (0 <= delta < 1)",
        in_range(DELTA_MIN, DELTA_MAX, include_high=False),
        read_only=True,
    ),
    ParameterSpec(
        "publish_rate",
        20.0,
        "rate (Hz of the node clock) of the physics ticks and the part state messages",
        positive,
        read_only=True,
    ),
    ParameterSpec(
        "time_step",
        2e-4,
        "integration step (s of simulated time); a tick runs the whole steps of the node-clock time elapsed",
        _time_step,
        read_only=True,
    ),
    ParameterSpec(
        "max_steps_per_tick",
        0,
        "most integration steps one tick runs (runtime); the rest of a late tick's time is dropped and "
        f"counted as steps_dropped. 0: the steps of {AUTO_CATCH_UP_TICKS} periods times "
        "max(1, real_time_factor)",
        integer_at_least(0),
    ),
    ParameterSpec(
        "damping",
        DEFAULT_DAMPING,
        "viscous surface drag per unit area (N s/m^3): v = F/(damping A); runtime: applied to the scene",
        positive,
    ),
    ParameterSpec(
        "friction",
        DEFAULT_FRICTION,
        "Coulomb friction coefficient with the surface, dynamic fidelity only (refused for the others); "
        "runtime: applied to the running scene",
        non_negative,
    ),
    ParameterSpec(
        "seed",
        0,
        "seed of the random initial poses (the simulation itself is deterministic)",
        integer,
        read_only=True,
    ),
    ParameterSpec(
        "frame_id",
        "",
        f"frame of the published poses (the plane frame); empty: {BASE_FRAME} under the node's namespace",
        read_only=True,
    ),
    ParameterSpec(
        "marker_force_stride",
        0,
        "~/markers draws the force of every k-th cell in each direction (0: no force vectors); runtime",
        integer_at_least(0),
    ),
    *VIZ_PARAMETERS,
)

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


def _stamp(nanoseconds: int) -> Time:
    """Return a node-clock time (integer ns) as a message stamp."""
    return RclTime(nanoseconds=nanoseconds).to_msg()


class MemsFieldArray(ManagedDevice):
    """Publishes ~/part_states, ~/part_poses at publish_rate and ~/field_program, ~/cell_forces, ~/parts.

    Serves ~/set_program and ~/place_parts (refused unless the device is ready), the action
    ~/run_program, plus the device services of ``ManagedDevice`` (~/stop, ~/reset, ~/inject_fault;
    ~/status, /diagnostics).
    """

    FAULTS = FAULTS

    def __init__(self) -> None:
        super().__init__(NODE_NAME, PARAMETERS, rate=20.0)
        self.scene: Scene | None = None
        self.goal_running = False
        self.goal_wake: Future | None = None
        self._release()
        serve(self, FieldSetProgram, "~/set_program", service_guard(self)(self.on_set_program))
        serve(self, MemsPlaceParts, "~/place_parts", service_guard(self)(self.on_place_parts))
        serve_device_action(
            self, RunProgram, "~/run_program", self.validate_run_program, self.execute_run_program
        )
        self.viz = DeviceViz(self, self.drawing)

    def _release(self) -> None:
        """Forget the scene and everything configure or activate made (publishers, timer)."""
        self.scene = None
        self.names: list[str] = []
        self.documents: list[dict[str, Any]] = []
        self.initial = np.zeros((0, 3))
        self.frame_id = ""
        self.step_ns = 1
        self.timer: Any = None
        self.publishers_made: list[Any] = []
        self.last_tick_ns = 0
        self.owed_ns = 0
        self.last_cells: tuple[Any, ...] | None = None
        self.last_grid_forces = np.zeros((0, 0, 2))
        self.part_triangles: tuple[Scene | None, list[np.ndarray]] = (None, [])
        # (cell forces drawn, (nx, ny, pitch, stride), shapes): the array's static drawing, rebuilt on change.
        self.array_drawing: tuple[np.ndarray | None, tuple[Any, ...], list[Any]] = (None, (), [])
        self.last_activity: tuple[bool, int, bool] | None = None
        self.program_stamp = 0
        self.count = {"steps": 0, "steps_dropped": 0, "programs": 0, "placements": 0, "program_goals": 0}
        self.predictions: dict[tuple[int, Field], Prediction] = {}

    # --- configure / activate / deactivate / cleanup ----------------------------------------------
    def configure_device(self, p: dict[str, Any]) -> None:
        """Load the parts and the program and build the scene; raise InputError naming the field."""
        self._release()
        parts: list[Part] = []
        documents: list[dict[str, Any]] = []
        for index, path in enumerate(p["part_files"]):
            if not path:
                continue
            try:
                parts.append(load_part(path))
                documents.append(load_yaml_mapping(path))
            except InputError as error:
                raise InputError(f"parameter part_files[{index}]", str(error)) from None
        poses = list(p["initial_poses"])
        if poses in ([], [0.0]):
            poses = random_poses(len(parts), p["placement_radius"], p["seed"]).ravel().tolist()
        if len(poses) != 3 * len(parts) or not all(
            isinstance(v, (int, float)) and math.isfinite(v) for v in poses
        ):
            raise InputError(
                "parameter initial_poses",
                f"needs 3 finite numbers per part ({3 * len(parts)}), got {len(poses)}",
            )
        program: tuple[ProgramStep, ...]
        if p["program_file"]:
            try:
                program = program_from_mapping(load_yaml_mapping(p["program_file"]))
            except InputError as error:
                raise InputError(
                    "parameter program_file", str(error.with_source(p["program_file"]))
                ) from None
        else:
            program = (ProgramStep(CombinedField(p["default_delta"]), math.inf),)
        if p["friction"] != 0.0 and p["fidelity"] != "dynamic":
            raise InputError(
                "parameter friction",
                f"Coulomb friction acts only in the dynamic fidelity; fidelity is {p['fidelity']!r} "
                "(leave friction 0 or choose dynamic)",
            )
        initial = np.array(poses, float).reshape(-1, 3)
        nx, ny = p["array_size"]
        self.scene = Scene(
            [Body(part, pose.copy()) for part, pose in zip(parts, initial, strict=True)],
            program,
            p["fidelity"],
            array=(nx, ny, p["pitch"]),
            directions=p["directions"],
            damping=p["damping"],
            friction=p["friction"],
        )
        self.initial, self.documents = initial, documents
        self.names = [
            doc["name"] if isinstance(doc.get("name"), str) else f"part{i}" for i, doc in enumerate(documents)
        ]
        self.frame_id = p["frame_id"] or self.frame(BASE_FRAME)
        self.step_ns = int(round(p["time_step"] * NANOSECONDS))
        self.expect_rate(p["publish_rate"])
        self.program_pub = self._publisher(FieldProgram, "~/field_program", LATCHED)
        self.cells_pub = self._publisher(MemsCellForces, "~/cell_forces", LATCHED)
        self.parts_pub = self._publisher(MemsParts, "~/parts", LATCHED)
        self.state_pub = self._publisher(MemsPartStates, "~/part_states", STREAM_DEPTH, lifecycle=True)
        self.pose_pub = self._publisher(PoseArray, "~/part_poses", STREAM_DEPTH, lifecycle=True)
        self.parts_pub.publish(MemsParts(parts=[part_to_msg(d) for d in documents]))
        self.program_stamp = self.get_clock().now().nanoseconds
        self.publish_program()
        self.publish_cells()

    def _publisher(self, msg_type: Any, topic: str, qos: Any, lifecycle: bool = False) -> Any:
        """Create a publisher (a lifecycle one for the streams) that cleanup destroys."""
        make = self.create_lifecycle_publisher if lifecycle else self.create_publisher
        publisher = make(msg_type, topic, qos)
        self.publishers_made.append((publisher, lifecycle))
        return publisher

    def activate_device(self) -> None:
        """Start the physics from now: the paused time is not simulated."""
        self.last_tick_ns = self.get_clock().now().nanoseconds
        self.owed_ns = 0
        self.last_activity = None
        if self.program_stamp <= 0 < self.last_tick_ns:  # configured before the (sim) clock had started
            self.program_stamp = self.last_tick_ns
            self.publish_program()
        self.timer = self.create_timer(1.0 / self.p["publish_rate"], self.tick)

    def deactivate_device(self) -> None:
        """Freeze the physics where it is: the timer goes, the scene and the latched messages stay."""
        if self.timer is not None:
            self.destroy_timer(self.timer)
            self.timer = None

    def cleanup_device(self) -> None:
        """Release the scene, the timer and every publisher configure made."""
        self.deactivate_device()
        for publisher, lifecycle in self.publishers_made:
            if lifecycle:
                self.destroy_lifecycle_publisher(publisher)
            else:
                self.destroy_publisher(publisher)
        self._release()

    # --- runtime parameters, status, stop/reset ----------------------------------------------------
    def apply_parameter(self, name: str, value: Any) -> None:
        """Apply damping, friction or max_steps_per_tick to the running scene (the others are read-only)."""
        if self.scene is None:
            return
        try:
            if name == "damping":
                self.scene.set_damping(float(value))
            elif name == "friction":
                self.scene.set_friction(float(value))
        except InputError as error:
            raise InputError(f"parameter {name}", error.problem) from None
        # max_steps_per_tick is read from self.p at every tick, which the kit updates after this returns

    def busy(self) -> bool:
        """Whether a ~/run_program goal executes, a program is before its last step or a part moves."""
        if self.goal_running:
            return True
        if self.scene is None or not self.scene.switched_on or self.scene.faults.power_loss:
            return False
        return not self.scene.on_last_step() or not all(self.scene.settled())

    def counters(self) -> dict[str, int]:
        """Return steps simulated and dropped, programs set, placements, goals, parts at rest, stiff steps."""
        settled = sum(self.scene.settled()) if self.scene is not None else 0
        stiff = self.scene.stiff_steps if self.scene is not None else 0
        return {**self.count, "parts_settled": settled, "stiff_steps": stiff}

    def warning_fault(self) -> tuple[int, str] | None:
        """Return an injected non-stopping fault, else FAULT_TIME_STEP while the step is too stiff."""
        return super().warning_fault() or self.time_step_warning()

    def time_step_warning(self) -> tuple[int, str] | None:
        """Return (FAULT_TIME_STEP, why) when the present program or drag has had stiff ideal steps."""
        scene = self.scene
        if scene is None or scene.stiff_since_mark == 0:
            return None
        dt = float(self.p["time_step"])
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
        nx, ny = self.p["array_size"]
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
        nx, ny = self.p["array_size"]
        pitch = self.p["pitch"]
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
        nx, ny = self.p["array_size"]
        layout = (nx, ny, self.p["pitch"], int(self.p["marker_force_stride"]))
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
        cap = int(self.p["max_steps_per_tick"])
        if cap > 0:
            return cap
        factor = max(1.0, float(self.p["real_time_factor"]))
        period_ns = NANOSECONDS * factor / float(self.p["publish_rate"])
        return max(1, math.ceil(AUTO_CATCH_UP_TICKS * period_ns / self.step_ns))

    def tick(self) -> None:
        """Advance the scene by the node-clock time since the last tick (capped) and publish the states."""
        scene = self.scene
        if scene is None or not self.active:
            return
        now = self.get_clock().now().nanoseconds
        if not self.tick_due(now):
            return
        if self.last_tick_ns <= 0:  # activated before the node clock started: from its first reading
            self.last_tick_ns = self.clock_origin_ns() or now
        elapsed = max(0, now - self.last_tick_ns)  # a clock set back simulates nothing, never negative
        self.last_tick_ns = now
        self.owed_ns += elapsed
        steps, self.owed_ns = divmod(self.owed_ns, self.step_ns)
        cap = self._max_steps()
        if steps > cap:
            self.count["steps_dropped"] += steps - cap
            steps = cap
        dt = float(self.p["time_step"])
        for _ in range(steps):
            scene.step(dt)
        self.count["steps"] += steps
        self.record_tick(scene.time)
        self.publish_cells()
        states = MemsPartStates(parts=self.part_states())
        states.header.stamp = _stamp(now)
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
    def on_set_program(
        self, request: FieldSetProgram.Request, response: FieldSetProgram.Response
    ) -> FieldSetProgram.Response:
        """Start the requested field program now (refused while a ~/run_program goal executes)."""
        self.require_ready("set_program")
        if self.goal_running:
            raise DeviceError("set_program refused: a ~/run_program goal is executing; cancel it first")
        program = program_from_msg(request.program)
        self.install_program(program)
        self.count["programs"] += 1
        self.publish_status()
        return response

    def install_program(self, program: tuple[ProgramStep, ...]) -> None:
        """Start ``program`` now and publish it (latched, stamped with its start) and the cells' forces."""
        assert self.scene is not None  # ready implies configured
        self.scene.set_program(program)
        self.program_stamp = self.get_clock().now().nanoseconds
        self.publish_program()
        self.publish_cells()

    def on_place_parts(
        self, request: MemsPlaceParts.Request, response: MemsPlaceParts.Response
    ) -> MemsPlaceParts.Response:
        """Put named parts at requested poses at rest, or every part back at its initial pose."""
        self.require_ready("place_parts")
        assert self.scene is not None  # ready implies configured
        if request.reset:
            for body, pose in zip(self.scene.bodies, self.initial, strict=True):
                body.pose, body.velocity = pose.copy(), np.zeros(3)
            self.count["placements"] += 1
            self.publish_status()
            return response
        n = len(request.names)
        check_count(n, MAX_NAMES, "names", "names")
        reach = self.placement_reach()
        for key in ("x", "y", "theta"):
            values = list(getattr(request, key))
            if len(values) != n:
                raise InputError(key, f"needs one value per name ({n}), got {len(values)}")
            bad = [i for i, v in enumerate(values) if not math.isfinite(v)]
            if bad:
                raise InputError(f"{key}[{bad[0]}]", "must be finite")
            limit = reach if key != "theta" else MAX_PLACE_ANGLE
            far = [i for i, v in enumerate(values) if abs(v) > limit]
            if far:
                unit = "rad" if key == "theta" else "m (the array's extent)"
                raise InputError(
                    f"{key}[{far[0]}]", f"must be within +-{limit:.6g} {unit}, got {values[far[0]]:.6g}"
                )
        targets = []
        for i, name in enumerate(request.names):
            if name not in self.names:
                raise InputError(f"names[{i}]", f"no part named {name!r} (parts: {', '.join(self.names)})")
            targets.append((self.names.index(name), np.array([request.x[i], request.y[i], request.theta[i]])))
        for index, pose in targets:
            body = self.scene.bodies[index]
            body.pose, body.velocity = pose, np.zeros(3)
        self.count["placements"] += 1
        self.publish_status()
        return response

    def placement_reach(self) -> float:
        """Return the largest |x| or |y| (m) a part may be placed at: the array's extent, with a margin.

        A part placed far off the array only drifts in no field; one at 1e308 m makes the model's
        arithmetic overflow into NaN poses for every subscriber, so placements stay near the array.
        """
        nx, ny = self.p["array_size"]
        return PLACE_REACH_FACTOR * max(nx, ny) * float(self.p["pitch"])

    # --- ~/run_program --------------------------------------------------------------------------------
    def validate_run_program(self, goal: RunProgram.Goal) -> None:
        """Check a goal's fields (the kit has checked that the device is ready and free).

        The program is checked by the one validation ``~/set_program`` uses, so both refuse the same
        programs naming the same fields (``program.steps[1].delta``).
        """
        program_from_msg(goal.program)
        check_timeout(goal.timeout)
        settling_criterion(goal.tolerance, goal.dwell)

    def prediction(self, index: int, field: Field) -> Prediction:
        """Return the planner's stable equilibria of part ``index`` in ``field`` (computed once per field)."""
        assert self.scene is not None
        key = (index, field)
        if key not in self.predictions:
            self.predictions[key] = predict(self.scene.bodies[index].part, field)
        return self.predictions[key]

    def wait_tick_or_cancel(self) -> Future:
        """Return a future done after the next tick, on deactivation, or when a cancel is requested."""
        wake = Future()
        self.next_tick().add_done_callback(lambda _: wake.done() or wake.set_result(True))
        self.goal_wake = wake
        return wake

    async def execute_run_program(self, goal_handle: ServerGoalHandle) -> RunProgram.Result:
        """Install the goal's program and follow it, tick by tick, until it ends (see RunProgram.action)."""
        goal = goal_handle.request
        program = program_from_msg(goal.program)
        criterion = settling_criterion(goal.tolerance, goal.dwell)
        timeout = check_timeout(goal.timeout)
        scene, names = self.scene, list(self.names)
        assert scene is not None  # accepted goals are on a ready, so configured, device
        self.install_program(program)
        self.count["program_goals"] += 1
        start_ns = self.program_stamp
        field = program[holding_step(program)].field
        judging_from = holding_start(program)
        predictions = [self.prediction(i, field) for i in range(len(scene.bodies))]
        detector = SettlingDetector(len(scene.bodies), criterion)
        settled = False
        elapsed = 0.0
        last_feedback = -math.inf
        self.goal_running = True
        self.publish_status()

        def poll_cancel() -> None:
            wake = self.goal_wake
            if goal_handle.is_cancel_requested and wake is not None and not wake.done():
                wake.set_result(True)

        poll = self.create_timer(
            1.0 / CANCEL_POLL_RATE, poll_cancel, clock=Clock(clock_type=ClockType.STEADY_TIME)
        )

        def end(outcome: int, text: str, fault: tuple[int, str] = (0, "")) -> RunProgram.Result:
            result = self.program_result(scene, names, outcome, text, settled, predictions, fault)
            if outcome == RunProgram.Result.SETTLED:
                goal_handle.succeed()
            elif outcome == RunProgram.Result.CANCELED:
                goal_handle.canceled()
            else:
                goal_handle.abort()
            self.get_logger().info(f"run_program {result.outcome_name}: {result.message}")
            return result

        try:
            while True:
                await self.wait_tick_or_cancel()
                if not self.active or self.scene is not scene:
                    return end(
                        RunProgram.Result.FAULT,
                        f"the device was deactivated ({self.state().name}) {elapsed:.3g} s into the goal; "
                        "the physics is frozen where it was",
                    )
                fault = self.stopping_fault()
                if fault is not None:
                    return end(RunProgram.Result.FAULT, f"the device faulted: {fault[1]}", fault)
                if self.stopped:
                    return end(
                        RunProgram.Result.FAULT,
                        "the device was stopped by ~/stop (cells off, parts where they are; "
                        "~/reset returns it to IDLE)",
                    )
                if goal_handle.is_cancel_requested:
                    return end(
                        RunProgram.Result.CANCELED,
                        f"canceled {elapsed:.3g} s into the goal: the program stays on (its last step "
                        "holds) and the parts were left where they are",
                    )
                now = self.last_tick_ns
                if start_ns <= 0:  # accepted before the node clock started: count from its first tick
                    start_ns = now
                elapsed = (now - start_ns) / NANOSECONDS
                judging = scene.time - scene.program_start >= judging_from
                flags = detector.update(elapsed, np.array([b.pose for b in scene.bodies]), judging)
                settled = judging and detector.all_settled
                if settled and (warning := self.time_step_warning()) is not None:
                    # At rest, but possibly where an unstable step stopped them: not certified.
                    settled = False
                    return end(
                        RunProgram.Result.FAULT,
                        f"every part stopped moving {elapsed:.3g} s into the goal, but {warning[1]}",
                        warning,
                    )
                if settled:
                    return end(RunProgram.Result.SETTLED, f"every part settled {elapsed:.3g} s into the goal")
                if elapsed >= timeout:
                    moving = [n for n, done in zip(names, flags, strict=True) if not done]
                    why = "the program had not reached its last step" if not judging else ""
                    return end(
                        RunProgram.Result.TIMEOUT,
                        f"timeout {timeout:g} s passed with {len(moving)} of {len(flags)} parts not settled "
                        f"({', '.join(moving)}){'; ' + why if why else ''}",
                    )
                if elapsed - last_feedback >= FEEDBACK_PERIOD - 1e-9:
                    last_feedback = elapsed
                    matches = [match(p, b.pose) for p, b in zip(predictions, scene.bodies, strict=True)]
                    goal_handle.publish_feedback(
                        RunProgram.Feedback(
                            time=elapsed,
                            parts=self.part_states(scene, names),
                            settled=list(flags),
                            equilibrium_distance=[m.distance for m in matches],
                        )
                    )
        finally:
            self.destroy_timer(poll)
            self.goal_wake = None
            self.goal_running = False

    def program_result(
        self,
        scene: Scene,
        names: list[str],
        outcome: int,
        text: str,
        settled: bool,
        predictions: list[Prediction],
        fault: tuple[int, str],
    ) -> RunProgram.Result:
        """Return the result of a goal: final states, and per part the predicted equilibrium reached."""
        matches = [match(p, b.pose) for p, b in zip(predictions, scene.bodies, strict=True)]
        summary = [
            self._equilibrium_summary(name, prediction, found)
            for name, prediction, found in zip(names, predictions, matches, strict=True)
        ]
        return RunProgram.Result(
            outcome=outcome,
            outcome_name=OUTCOME_NAMES[outcome],
            message="; ".join([text, *summary]),
            settled=settled,
            parts=self.part_states(scene, names),
            equilibrium=[m.index for m in matches],
            equilibrium_theta=[m.theta for m in matches],
            equilibrium_distance=[m.distance for m in matches],
            fault_code=int(fault[0]),
            fault_text=fault[1],
        )

    @staticmethod
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
    run_node(MemsFieldArray, NODE_NAME, args)


if __name__ == "__main__":
    main()
