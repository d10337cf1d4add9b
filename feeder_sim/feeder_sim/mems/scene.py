"""A scene on the field array: parts, a field program, a fidelity level and the motion law."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import ConstantField, Field, ProgramStep
from feeder_sim.mems.bodies import (
    FIDELITIES,
    Body,
    Fidelity,
    ForceModel,
    check_fidelity,
    drag_coefficients,
    wrench_on,
)
from feeder_sim.mems.coverage import Grid
from feeder_sim.mems.dynamic import DynamicWorld
from feeder_sim.mems.faults import ArrayFaults
from feeder_sim.mems.models import ArrayForces, IdealForces
from feeder_sim.mems.stepping import IdealStepper
from feeder_sim.mems.tolerances import (
    DEFAULT_CELLS,
    DEFAULT_DAMPING,
    DEFAULT_FRICTION,
    DEFAULT_PITCH,
    GRAVITY,
    SETTLED_ANGULAR_SPEED,
    SETTLED_SPEED,
    STIFF_STEP_RATIO,
)

__all__ = ["FIDELITIES", "Fidelity", "Body", "Scene", "random_poses", "FIELD_OFF"]

# What the cells push with while the array is switched off (a stopped device): nothing.
FIELD_OFF: Field = ConstantField((0.0, 0.0))


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
    for several parts). Injected faults (``faults.ArrayFaults``) act through the force model;
    ``switched_on`` False is an array whose cells push with nothing (a stopped device).
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
        self.friction = float(friction)
        self.time = 0.0
        self._switched_on = True
        # The ideal model's integrator (stepping.py): error control, the stability limit
        # (STIFF_STEP_RATIO: stiff steps in all, and their count at the last mark_steps()) and rest.
        self.stepper = IdealStepper()
        self._stiff_at_mark = 0
        self.set_program(program)
        self.forces: ForceModel = (
            ArrayForces(*array, directions=directions) if self.fidelity == "array" else IdealForces()
        )
        self._dynamic = (
            DynamicWorld(bodies, self.forces, self.damping, friction, gravity)
            if self.fidelity == "dynamic"
            else None
        )

    @property
    def switched_on(self) -> bool:
        """Whether the cells push (False: a stopped device, every cell off)."""
        return self._switched_on

    @switched_on.setter
    def switched_on(self, on: bool) -> None:
        self._switched_on = bool(on)
        self.stepper.wake()

    @property
    def faults(self) -> ArrayFaults:
        """Return the injected faults in force."""
        return self.forces.faults

    def set_faults(self, faults: ArrayFaults) -> None:
        """Put ``faults`` in force; cell faults without cells raise InputError naming ``fault``."""
        if faults.has_cell_faults and not isinstance(self.forces, ArrayForces):
            raise InputError(
                "fault", f"dead and stuck cells need fidelity 'array'; this scene is {self.fidelity!r}"
            )
        self.forces.set_faults(faults)
        self.stepper.wake()

    def inject_fault(
        self,
        name: str,
        *,
        value: float,
        indices: Sequence[int],
        angle: float,
        seed: int,
        cells: Sequence[int],
    ) -> None:
        """Put one more fault in force (``ArrayFaults.with_fault`` validates it, naming the field)."""
        self.set_faults(
            self.faults.with_fault(
                name,
                value=value,
                indices=indices,
                angle=angle,
                seed=seed,
                cells=(cells[0], cells[1]),
                fidelity=self.fidelity,
            )
        )

    def set_damping(self, damping: float) -> None:
        """Change the viscous surface drag (N s/m^3) from the next step on."""
        if not (math.isfinite(damping) and damping > 0):
            raise InputError("damping", f"must be a finite number > 0, got {damping!r}")
        self.damping = float(damping)
        self.mark_steps()  # the stiffness scales with 1 / damping: judged afresh
        self.stepper.wake()
        if self._dynamic is not None:
            self._dynamic.damping = self.damping

    def set_friction(self, friction: float) -> None:
        """Change the Coulomb surface friction from the next step on (only the 'dynamic' fidelity has it)."""
        if not (math.isfinite(friction) and friction >= 0):
            raise InputError("friction", f"must be a finite number >= 0, got {friction!r}")
        if self._dynamic is None:
            raise InputError(
                "friction",
                f"Coulomb friction acts only in the 'dynamic' fidelity; this scene is {self.fidelity!r} "
                "(quasi-static: viscous drag only)",
            )
        self.friction = self._dynamic.friction = float(friction)

    def mark_steps(self) -> None:
        """Judge the ideal model's steps afresh (a new program or drag): stiff_since_mark, peak ratio."""
        self._stiff_at_mark = self.stepper.stiff_steps
        self.stepper.peak_ratio = 0.0

    @property
    def stiff_steps(self) -> int:
        """Return the steps of dt the ideal model had to cut for stability (STIFF_STEP_RATIO), in all."""
        return self.stepper.stiff_steps

    @property
    def stiff_since_mark(self) -> int:
        """Return the stiff steps since the last mark_steps()."""
        return self.stepper.stiff_steps - self._stiff_at_mark

    @property
    def peak_step_ratio(self) -> float:
        """Return the largest lambda dt met since mark_steps() (|k2 - k1| / |k1| scaled to the full dt)."""
        return self.stepper.peak_ratio

    def stable_step_estimate(self, dt: float) -> float:
        """Return the step (s) that would have kept the peak ratio since mark_steps() at STIFF_STEP_RATIO.

        The ratio is lambda dt of the stiffest mode met, so it scales with the step; inf before any
        step was judged.
        """
        peak = self.peak_step_ratio
        return dt * STIFF_STEP_RATIO / peak if peak > 0 else math.inf

    def stiffness_warning(self, dt: float) -> str:
        """Say why steps of ``dt`` are beyond the ideal model's margin since mark_steps(), or "" if not.

        Only a dt the model actually had to cut for stability warns, so the step it names is shorter
        than ``dt``.
        """
        if self.stiff_since_mark == 0:
            return ""
        return (
            f"time_step {dt:g} s is beyond the ideal model's stability margin at damping {self.damping:g}: "
            f"{self.stiff_since_mark} steps had to be cut, a part's velocity changing by up to "
            f"{self.peak_step_ratio:.2f} times itself over a full step (margin {STIFF_STEP_RATIO:g}; from 2 "
            "a step stops a part off its equilibrium). The poses stay within the step error tolerance, "
            "but the device computes finer steps than configured, and a settling is not certified at "
            f"this time_step; a time_step of {self.stable_step_estimate(dt):.2g} s or less, or more "
            "damping, keeps the margin"
        )

    def add_body(self, body: Body) -> None:
        """Add ``body`` (at its pose and velocity) from the next step on, at every fidelity.

        The ideal model keeps its other bodies' steps and rests; the dynamic world takes the body into its
        collision space (built once there are several parts).
        """
        self.bodies.append(body)
        self.stepper.added(len(self.bodies))
        if self._dynamic is not None:
            self._dynamic.added()

    def remove_body(self, index: int) -> Body:
        """Take body ``index`` out of the scene and return it; the others keep their state."""
        body = self.bodies.pop(index)
        self.stepper.removed(index, len(self.bodies))
        if self._dynamic is not None:
            self._dynamic.removed(index)
        return body

    def place_body(self, index: int, pose: np.ndarray) -> None:
        """Put body ``index`` at ``pose`` (x, y, theta), at rest, from the next step on (every fidelity)."""
        body = self.bodies[index]
        body.pose, body.velocity = np.array(pose, float), np.zeros(3)
        if self._dynamic is not None:
            self._dynamic.placed(index)

    def set_program(self, program: tuple[ProgramStep, ...]) -> None:
        """Start ``program`` now (its first step's time counts from the current scene time)."""
        self.program = tuple(program)
        self.program_start = self.time
        self.mark_steps()
        self.stepper.wake()

    def active_field(self) -> Field:
        """Return the field of the program step active now; the last step stays on when the program ends."""
        elapsed = self.time - self.program_start
        for step in self.program:
            if elapsed < step.duration:
                return step.field
            elapsed -= step.duration
        return self.program[-1].field

    def output_field(self) -> Field:
        """Return the field the cells are driven with now: the program's, or nothing when switched off."""
        return self.active_field() if self.switched_on else FIELD_OFF

    def cell_forces(self, field: Field, grid: Grid) -> np.ndarray:
        """Return what the cells of ``grid`` push with in ``field``, (nx, ny, 2), faults included.

        The array model's own cells; for ideal and dynamic, the ideal field sampled at the cell centres.
        """
        forces = self.forces.cell_forces(field)
        if forces is None:
            forces = self.faults.apply_to_cells(field.force_density(grid.centers()))
        return forces

    def on_last_step(self) -> bool:
        """Whether the program has reached its last step (which stays on until the next program)."""
        return self.time - self.program_start >= sum(step.duration for step in self.program[:-1])

    def settled(self) -> list[bool]:
        """Return, per body, whether it is at rest (speeds below SETTLED_SPEED, SETTLED_ANGULAR_SPEED)."""
        return [
            bool(math.hypot(b.velocity[0], b.velocity[1]) < SETTLED_SPEED)
            and bool(abs(b.velocity[2]) < SETTLED_ANGULAR_SPEED)
            for b in self.bodies
        ]

    def _rate(self, body: Body, pose: np.ndarray, field_now: Field) -> tuple[np.ndarray, np.ndarray]:
        """Return the quasi-static velocity (F / damping A, M / damping J) at ``pose`` and the wrench."""
        return self._rate_with(body, pose, field_now, drag_coefficients(body.part, self.damping))

    def _rate_with(
        self, body: Body, pose: np.ndarray, field_now: Field, drag: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return ``_rate`` with the body's drag coefficients given (the same through a step of dt)."""
        w = wrench_on(body, self.forces, field_now, pose)
        return w / drag, w

    def step(self, dt: float) -> None:
        """Advance by dt seconds in the field active at the start of the step.

        'ideal': Heun's method with error control and a stability limit, in steps of at most dt, and
        nothing for a part at rest (``stepping.IdealStepper``; ``stiff_steps`` counts the dt that needed
        a cut); 'array': forward Euler, whose cell discretisation error dominates the step error (one
        force evaluation per step, unmonitored: its cell forces change in jumps as edges cross cells);
        'dynamic' by its world.
        """
        field_now = self.output_field()
        if self._dynamic is not None:
            self._dynamic.step(dt, field_now)
        elif self.fidelity == "ideal":
            self.stepper.prepare(len(self.bodies), (field_now, self.faults, self.damping))
            for index, body in enumerate(self.bodies):
                moved = self.stepper.advance(
                    index,
                    body.pose,
                    dt,
                    partial(
                        self._rate_with,
                        body,
                        field_now=field_now,
                        drag=self.damping * body.unit_drag,  # drag_coefficients to the bit, kept
                    ),
                    body.frame.radius,
                )
                if moved is not None:
                    body.pose, body.velocity, body.wrench = moved
        else:
            for body in self.bodies:
                k1, w = self._rate(body, body.pose, field_now)
                body.velocity = k1
                body.pose = body.pose + dt * body.velocity
                body.pose[2] = math.remainder(body.pose[2], 2 * math.pi) % (2 * math.pi)
                body.wrench = w
        self.time += dt

    def run(self, duration: float, dt: float) -> None:
        """Advance by ``duration`` seconds in steps of dt (rounded to a whole number of steps)."""
        for _ in range(int(round(duration / dt))):
            self.step(dt)
