"""A scene on the field array: parts, a field program, a fidelity level and the motion law."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import Field, ProgramStep
from feeder_planner.parts import Part
from feeder_sim.mems.models import ArrayForces, IdealForces

FIDELITIES = ("ideal", "array", "dynamic")


@dataclass
class Body:
    """A part on the array: pose (x, y, theta) of its centroid and velocity (vx, vy, omega)."""

    part: Part
    pose: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    wrench: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def loops(self, pose: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        p = self.pose if pose is None else pose
        return self.part.placed(float(p[0]), float(p[1]), float(p[2]))


class Scene:
    """Parts driven by a field program. ``ideal`` and ``array`` are quasi-static: a uniform viscous
    surface drag ``damping`` (N s/m^3) per unit area gives v = F / (damping A), omega = M / (damping J)
    with J the polar moment of area; ``dynamic`` adds inertia, Coulomb friction and collisions.
    """

    def __init__(
        self,
        bodies: list[Body],
        program: tuple[ProgramStep, ...],
        fidelity: str = "ideal",
        array: tuple[int, int, float] = (100, 100, 1e-4),
        directions: int = 0,
        damping: float = 1.0,
        friction: float = 0.0,
        gravity: float = 9.81,
    ) -> None:
        if fidelity not in FIDELITIES:
            raise InputError(
                "fidelity", f"unknown fidelity {fidelity!r} (expected one of {', '.join(FIDELITIES)})"
            )
        if not program:
            raise InputError("program", "a field program needs at least one step")
        self.bodies = bodies
        self.fidelity = fidelity
        self.damping = float(damping)
        self.time = 0.0
        self.set_program(program)
        self.forces = ArrayForces(*array, directions=directions) if fidelity == "array" else IdealForces()
        self._dynamic = None
        if fidelity == "dynamic":
            from feeder_sim.mems.dynamic import DynamicWorld  # pymunk only when it is asked for

            self._dynamic = DynamicWorld(self, friction, gravity)

    def set_program(self, program: tuple[ProgramStep, ...]) -> None:
        self.program = tuple(program)
        self.program_start = self.time

    def active_field(self) -> Field:
        """The field of the program step active now; the last step stays on when the program ends."""
        elapsed = self.time - self.program_start
        for step in self.program:
            if elapsed < step.duration:
                return step.field
            elapsed -= step.duration
        return self.program[-1].field

    def wrench(self, body: Body, pose: np.ndarray, field_now: Field) -> np.ndarray:
        return self.forces.wrench(field_now, body.loops(pose), pose[:2])

    def _rate(self, body: Body, pose: np.ndarray, field_now: Field) -> tuple[np.ndarray, np.ndarray]:
        w = self.wrench(body, pose, field_now)
        part = body.part
        return np.array(
            [
                w[0] / (self.damping * part.area),
                w[1] / (self.damping * part.area),
                w[2] / (self.damping * part.polar_moment),
            ]
        ), w

    def step(self, dt: float) -> None:
        """Advance by dt seconds: Heun's method for 'ideal'; forward Euler for 'array', whose cell
        discretisation error dominates the step error (one force evaluation per step).
        """
        field_now = self.active_field()
        if self._dynamic is not None:
            self._dynamic.step(dt, field_now)
        else:
            for body in self.bodies:
                k1, w = self._rate(body, body.pose, field_now)
                if self.fidelity == "ideal":
                    k2, _ = self._rate(body, body.pose + dt * k1, field_now)
                    body.velocity = 0.5 * (k1 + k2)
                else:
                    body.velocity = k1
                body.pose = body.pose + dt * body.velocity
                body.pose[2] = math.remainder(body.pose[2], 2 * math.pi) % (2 * math.pi)
                body.wrench = w
        self.time += dt

    def run(self, duration: float, dt: float) -> None:
        for _ in range(int(round(duration / dt))):
            self.step(dt)
