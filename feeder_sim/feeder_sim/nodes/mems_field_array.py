"""ROS 2 node: the simulated MEMS field array (thin adapter around feeder_sim.mems)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from feeder_msgs.msg import (
    FieldProgram,
    FieldSpec,
    MemsCellForces,
    MemsParts,
    MemsPartState,
    MemsPartStates,
)
from feeder_msgs.srv import FieldSetProgram, MemsPlaceParts
from feeder_planner.errors import InputError
from feeder_planner.fields_io import load_yaml_mapping
from feeder_planner.mems import DELTA_MAX, DELTA_MIN, CombinedField, Field, ProgramStep, program_from_mapping
from feeder_planner.node_kit import (
    LATCHED,
    STREAM_DEPTH,
    ParameterSpec,
    declare_parameters,
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
from feeder_planner.node_kit.msg_fields import fill_field_spec, program_from_msg
from feeder_planner.node_kit.msg_parts import part_to_msg
from feeder_planner.parts import Part, load_part
from feeder_sim.mems import FIDELITIES, Body, Grid, Scene, random_poses
from feeder_sim.mems.tolerances import DEFAULT_CELLS, DEFAULT_DAMPING, DEFAULT_FRICTION, DEFAULT_PITCH

__all__ = ["PARAMETERS", "MemsFieldArray", "main"]


def _array_size(value: Sequence[object]) -> str | None:
    """Check the array_size parameter: two integers > 0."""
    ok = len(value) == 2 and all(isinstance(v, int) and v > 0 for v in value)
    return None if ok else f"must be two integers > 0 [nx, ny], got {list(value)!r}"


def _time(t: float) -> Time:
    """Return simulated time t (s) as a message time stamp."""
    return Time(sec=int(t), nanosec=int(round((t - int(t)) * 1e9)) % 1_000_000_000)


PARAMETERS = (
    ParameterSpec(
        "array_size", list(DEFAULT_CELLS), "number of actuator cells [nx, ny] of the array", _array_size
    ),
    ParameterSpec(
        "pitch",
        DEFAULT_PITCH,
        "side of one square actuator cell (m); the array is centred on the plane origin",
        positive,
    ),
    ParameterSpec(
        "fidelity",
        "ideal",
        "force model: ideal (exact field integrals, quasi-static), array (cells at "
        "the pitch, exact covered areas), dynamic (inertia, friction, collisions)",
        one_of(FIDELITIES),
    ),
    ParameterSpec(
        "directions",
        0,
        "quantise cell forces to this many actuator directions (0: exact directions)",
        integer_at_least(0),
    ),
    ParameterSpec("part_files", [""], "part files (YAML, contract section 2); empty entries are ignored"),
    ParameterSpec(
        "initial_poses",
        [0.0],
        "x, y, theta (m, m, rad) per part, flattened; [] or [0.0]: random poses "
        "within placement_radius drawn with the seed",
    ),
    ParameterSpec(
        "placement_radius", 1e-3, "radius (m) of the disc random initial positions are drawn in", positive
    ),
    ParameterSpec(
        "program_file",
        "",
        "field program YAML ({steps: [{field: {...}, duration: s}]}, metres); "
        "empty: combined field delta = default_delta forever",
    ),
    ParameterSpec(
        "default_delta",
        0.2,
        "delta of the default combined field (0 <= delta < 1)",
        in_range(DELTA_MIN, DELTA_MAX, include_high=False),
    ),
    ParameterSpec("publish_rate", 20.0, "rate (Hz, wall clock) of part state messages", positive),
    ParameterSpec(
        "real_time_factor", 1.0, "simulated seconds per wall second; > 1 also publishes /clock", positive
    ),
    ParameterSpec("time_step", 2e-4, "integration step (s of simulated time)", positive),
    ParameterSpec(
        "damping",
        DEFAULT_DAMPING,
        "viscous surface drag per unit area (N s/m^3): v = F/(damping A)",
        positive,
    ),
    ParameterSpec(
        "friction",
        DEFAULT_FRICTION,
        "Coulomb friction coefficient with the surface (dynamic fidelity)",
        non_negative,
    ),
    ParameterSpec(
        "seed",
        0,
        "seed of the random initial poses (the simulation itself is deterministic)",
        integer,
    ),
    ParameterSpec("frame_id", "mems_array", "frame of the published poses (the plane frame)"),
)


class MemsFieldArray(Node):
    """Publishes part states at a fixed rate, the field program and cell forces (latched).

    Serves /mems/set_program and /mems/place_parts.
    """

    def __init__(self) -> None:
        super().__init__("mems_field_array")
        p = declare_parameters(self, PARAMETERS)
        self.p = p
        files = [f for f in p["part_files"] if f]
        parts: list[Part] = []
        documents: list[dict[str, Any]] = []
        for path in files:
            parts.append(load_part(path))
            documents.append(load_yaml_mapping(path))
        poses = list(p["initial_poses"])
        if poses in ([], [0.0]):
            poses = random_poses(len(parts), p["placement_radius"], p["seed"]).ravel().tolist()
        if len(poses) != 3 * len(parts) or not all(math.isfinite(v) for v in poses):
            raise InputError(
                "parameter initial_poses",
                f"needs 3 finite numbers per part ({3 * len(parts)}), got {len(poses)}",
            )
        self.initial = np.array(poses, float).reshape(-1, 3)
        self.names = [
            doc.get("name", f"part{i}") if isinstance(doc.get("name"), str) else f"part{i}"
            for i, doc in enumerate(documents)
        ]
        program: tuple[ProgramStep, ...]
        if p["program_file"]:
            try:
                program = program_from_mapping(load_yaml_mapping(p["program_file"]))
            except InputError as error:
                raise error.with_source(p["program_file"]) from None
        else:
            program = (ProgramStep(CombinedField(p["default_delta"]), math.inf),)
        nx, ny = p["array_size"]
        self.scene = Scene(
            [Body(part, pose.copy()) for part, pose in zip(parts, self.initial, strict=True)],
            program,
            p["fidelity"],
            array=(nx, ny, p["pitch"]),
            directions=p["directions"],
            damping=p["damping"],
            friction=p["friction"],
        )
        self.state_pub = self.create_publisher(MemsPartStates, "/mems/part_states", STREAM_DEPTH)
        self.pose_pub = self.create_publisher(PoseArray, "/mems/part_poses", STREAM_DEPTH)
        self.program_pub = self.create_publisher(FieldProgram, "/mems/field_program", LATCHED)
        self.cells_pub = self.create_publisher(MemsCellForces, "/mems/cell_forces", LATCHED)
        self.parts_pub = self.create_publisher(MemsParts, "/mems/parts", LATCHED)
        self.clock_pub = self.create_publisher(Clock, "/clock", 10) if p["real_time_factor"] > 1 else None
        self.create_service(FieldSetProgram, "/mems/set_program", service_guard(self)(self.on_set_program))
        self.create_service(MemsPlaceParts, "/mems/place_parts", service_guard(self)(self.on_place_parts))
        self.parts_pub.publish(MemsParts(parts=[part_to_msg(d) for d in documents]))
        self.last_field: Field | None = None
        self.publish_program()
        self.create_timer(1.0 / p["publish_rate"], self.tick)

    def stamp(self) -> Time:
        """Return the scene's simulated time as a message time stamp."""
        return _time(self.scene.time)

    def publish_program(self) -> None:
        """Publish the scene's field program (latched), stamped with its start time."""
        msg = FieldProgram(
            name="program", steps=[fill_field_spec(FieldSpec(), s) for s in self.scene.program]
        )
        msg.header.frame_id = self.p["frame_id"]
        msg.header.stamp = _time(self.scene.program_start)
        self.program_pub.publish(msg)

    def publish_cells(self) -> None:
        """Publish the cell forces of the active field (latched) when the field has changed."""
        field = self.scene.active_field()
        if field is self.last_field:
            return
        self.last_field = field
        nx, ny = self.p["array_size"]
        pitch = self.p["pitch"]
        grid_forces = self.scene.forces.cell_forces(field)
        if grid_forces is None:  # ideal / dynamic: the ideal field sampled at the cell centres
            grid_forces = field.force_density(Grid(nx, ny, pitch).centers())
        msg = MemsCellForces(
            nx=nx,
            ny=ny,
            pitch=pitch,
            fx=grid_forces[..., 0].ravel().tolist(),
            fy=grid_forces[..., 1].ravel().tolist(),
        )
        msg.header.stamp = self.stamp()
        msg.header.frame_id = self.p["frame_id"]
        self.cells_pub.publish(msg)

    def tick(self) -> None:
        """Advance the scene by one publishing period of simulated time and publish the states."""
        p = self.p
        steps = max(1, int(round(p["real_time_factor"] / p["publish_rate"] / p["time_step"])))
        for _ in range(steps):
            self.scene.step(p["time_step"])
        self.publish_cells()
        states = MemsPartStates()
        states.header.stamp = self.stamp()
        states.header.frame_id = p["frame_id"]
        poses = PoseArray()
        poses.header = states.header
        for name, body in zip(self.names, self.scene.bodies, strict=True):
            state = MemsPartState(name=name, theta=float(body.pose[2]))
            state.pose = self._pose(body.pose)
            state.twist.linear.x, state.twist.linear.y = float(body.velocity[0]), float(body.velocity[1])
            state.twist.angular.z = float(body.velocity[2])
            state.wrench.force.x, state.wrench.force.y = float(body.wrench[0]), float(body.wrench[1])
            state.wrench.torque.z = float(body.wrench[2])
            states.parts.append(state)
            poses.poses.append(state.pose)
        self.state_pub.publish(states)
        self.pose_pub.publish(poses)
        if self.clock_pub is not None:
            self.clock_pub.publish(Clock(clock=self.stamp()))

    @staticmethod
    def _pose(pose: np.ndarray) -> Pose:
        """Return a pose (x, y, theta) as a Pose message."""
        return planar_pose(pose[0], pose[1], pose[2])

    def on_set_program(
        self, request: FieldSetProgram.Request, response: FieldSetProgram.Response
    ) -> FieldSetProgram.Response:
        """Start the requested field program now."""
        program = program_from_msg(request.program)
        self.scene.set_program(program)
        self.publish_program()
        self.publish_cells()
        return response

    def on_place_parts(
        self, request: MemsPlaceParts.Request, response: MemsPlaceParts.Response
    ) -> MemsPlaceParts.Response:
        """Put named parts at requested poses at rest, or every part back at its initial pose."""
        if request.reset:
            for body, pose in zip(self.scene.bodies, self.initial, strict=True):
                body.pose, body.velocity = pose.copy(), np.zeros(3)
            return response
        n = len(request.names)
        for key in ("x", "y", "theta"):
            values = list(getattr(request, key))
            if len(values) != n:
                raise InputError(key, f"needs one value per name ({n}), got {len(values)}")
            bad = [i for i, v in enumerate(values) if not math.isfinite(v)]
            if bad:
                raise InputError(f"{key}[{bad[0]}]", "must be finite")
        targets = []
        for i, name in enumerate(request.names):
            if name not in self.names:
                raise InputError(f"names[{i}]", f"no part named {name!r} (parts: {', '.join(self.names)})")
            targets.append((self.names.index(name), np.array([request.x[i], request.y[i], request.theta[i]])))
        for index, pose in targets:
            body = self.scene.bodies[index]
            body.pose, body.velocity = pose, np.zeros(3)
        return response


def main(args: list[str] | None = None) -> None:
    """Run the node until shut down."""
    run_node(MemsFieldArray, "mems_field_array", args)


if __name__ == "__main__":
    main()
