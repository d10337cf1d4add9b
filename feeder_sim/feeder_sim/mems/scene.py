"""A scene on the field array: parts, a field program, a fidelity level and the motion law."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import Field, ProgramStep
from feeder_sim.mems.bodies import (
    FIDELITIES,
    Body,
    Fidelity,
    ForceModel,
    check_fidelity,
    drag_coefficients,
    wrench_on,
)
from feeder_sim.mems.dynamic import DynamicWorld
from feeder_sim.mems.models import ArrayForces, IdealForces
from feeder_sim.mems.tolerances import (
    DEFAULT_CELLS,
    DEFAULT_DAMPING,
    DEFAULT_FRICTION,
    DEFAULT_PITCH,
    GRAVITY,
)

__all__ = ["FIDELITIES", "Fidelity", "Body", "Scene", "random_poses"]


def random_poses(count: int, radius: float, seed: int) -> np.ndarray:
    """Return (count, 3) poses: positions uniform in the disc of ``radius``, angles uniform, for a seed."""
    rng = np.random.default_rng(seed)
    r = radius * np.sqrt(rng.uniform(size=count))
    angle = rng.uniform(0, 2 * math.pi, size=count)
    return np.column_stack([r * np.cos(angle), r * np.sin(angle), rng.uniform(0, 2 * math.pi, size=count)])


class Scene:
    """Parts driven by a field program at one fidelity level.

    ``ideal`` and ``array`` are quasi-static: a uniform viscous surface drag ``damping`` (N s/m^3)
    per unit area gives v = F / (damping A), omega = M / (damping J) with J the polar moment of area;
    ``dynamic`` adds inertia, Coulomb friction and collisions (``DynamicWorld``; pymunk is loaded only
    for several parts).
    """

    def __init__(
        self,
        bodies: list[Body],
        program: tuple[ProgramStep, ...],
        fidelity: Fidelity | str = "ideal",
        array: tuple[int, int, float] = (*DEFAULT_CELLS, DEFAULT_PITCH),
        directions: int = 0,
        damping: float = DEFAULT_DAMPING,
        friction: float = DEFAULT_FRICTION,
        gravity: float = GRAVITY,
    ) -> None:
        self.fidelity: Fidelity = check_fidelity(fidelity)
        if not program:
            raise InputError("program", "a field program needs at least one step")
        self.bodies = bodies
        self.damping = float(damping)
        self.time = 0.0
        self.set_program(program)
        self.forces: ForceModel = (
            ArrayForces(*array, directions=directions) if self.fidelity == "array" else IdealForces()
        )
        self._dynamic = (
            DynamicWorld(bodies, self.forces, self.damping, friction, gravity)
            if self.fidelity == "dynamic"
            else None
        )

    def set_program(self, program: tuple[ProgramStep, ...]) -> None:
        """Start ``program`` now (its first step's time counts from the current scene time)."""
        self.program = tuple(program)
        self.program_start = self.time

    def active_field(self) -> Field:
        """Return the field of the program step active now; the last step stays on when the program ends."""
        elapsed = self.time - self.program_start
        for step in self.program:
            if elapsed < step.duration:
                return step.field
            elapsed -= step.duration
        return self.program[-1].field

    def _rate(self, body: Body, pose: np.ndarray, field_now: Field) -> tuple[np.ndarray, np.ndarray]:
        """Return the quasi-static velocity (F / damping A, M / damping J) at ``pose`` and the wrench."""
        w = wrench_on(body, self.forces, field_now, pose)
        return w / drag_coefficients(body.part, self.damping), w

    def step(self, dt: float) -> None:
        """Advance by dt seconds.

        Heun's method for 'ideal'; forward Euler for 'array', whose cell discretisation error
        dominates the step error (one force evaluation per step); 'dynamic' by its world.
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
        """Advance by ``duration`` seconds in steps of dt (rounded to a whole number of steps)."""
        for _ in range(int(round(duration / dt))):
            self.step(dt)
