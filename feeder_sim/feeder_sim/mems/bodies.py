"""What the scene and the dynamic world share: bodies on the array, fidelity levels, force models.

Neither the scene nor the dynamic world imports the other through this module: the scene builds a
dynamic world when asked for the 'dynamic' fidelity, and the world sees only bodies and a force model.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal, Protocol, get_args

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.mems.fields import Field
from feeder_planner.mems.frame import PartFrame
from feeder_planner.parts import Part
from feeder_sim.mems.faults import ArrayFaults

__all__ = [
    "Fidelity",
    "FIDELITIES",
    "check_fidelity",
    "Body",
    "ForceModel",
    "wrench_on",
    "drag_coefficients",
    "inertia",
]

# ideal: exact field integrals, quasi-static; array: actuator cells, quasi-static; dynamic: inertia,
# Coulomb friction and collisions.
Fidelity = Literal["ideal", "array", "dynamic"]
FIDELITIES: tuple[Fidelity, ...] = get_args(Fidelity)


def check_fidelity(fidelity: object, field: str = "fidelity") -> Fidelity:
    """Return ``fidelity`` if it is one of FIDELITIES, else raise InputError naming ``field``."""
    for known in FIDELITIES:
        if fidelity == known:
            return known
    raise InputError(field, f"unknown fidelity {fidelity!r} (expected one of {', '.join(FIDELITIES)})")


@dataclass
class Body:
    """A part on the array: pose (x, y, theta) of its centroid and velocity (vx, vy, omega)."""

    part: Part
    pose: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    wrench: np.ndarray = field(default_factory=lambda: np.zeros(3))  # field force and torque, last step

    @cached_property
    def frame(self) -> PartFrame:
        """Return the part's edges and moments in its own frame, built once (a body keeps its part)."""
        return PartFrame.of(self.part)

    @cached_property
    def unit_drag(self) -> np.ndarray:
        """Return the drag coefficients at unit damping, (A, A, J): damping times them is the drag."""
        return drag_coefficients(self.part, 1.0)

    def loops(self, pose: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """Return the part's loops placed at ``pose`` (default: the body's pose) in the plane frame."""
        p = self.pose if pose is None else pose
        return self.part.placed(float(p[0]), float(p[1]), float(p[2]))


class ForceModel(Protocol):
    """How a field acts on a placed part: 'ideal' exact integrals or 'array' actuator cells."""

    def wrench(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return (Fx, Fy, torque about ``about``) of the field on the placed loops."""
        ...

    def wrench_at(self, field: Field, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return the same wrench on the rigid part ``frame`` at ``pose`` (torque about its centroid)."""
        ...

    def cell_forces(self, field: Field) -> np.ndarray | None:
        """Return the (nx, ny, 2) cell forces for this field, or None without cells."""
        ...

    @property
    def faults(self) -> ArrayFaults:
        """Return the injected faults in force."""
        ...

    def set_faults(self, faults: ArrayFaults) -> None:
        """Put injected faults in force (a model without cells refuses cell faults)."""
        ...


def wrench_on(body: Body, forces: ForceModel, field: Field, pose: np.ndarray | None = None) -> np.ndarray:
    """Return the force model's wrench of ``field`` on the body at ``pose`` (default: its pose).

    The torque is about the part's centroid, the reference point of the motion law. Through the part's
    frame (``Body.frame``), so that a model that can (the ideal one) does not place the part at all.
    """
    p = body.pose if pose is None else pose
    return forces.wrench_at(field, body.frame, p)


def drag_coefficients(part: Part, damping: float) -> np.ndarray:
    """Return (damping A, damping A, damping J): uniform viscous surface drag on (vx, vy, omega).

    Drag per unit area ``damping`` (N s/m^3) integrated over the part: A its area, J its polar
    moment of area about the centroid.
    """
    return damping * np.array([part.area, part.area, part.polar_moment])


def inertia(part: Part) -> np.ndarray:
    """Return (m, m, I): the part's mass twice and its moment of inertia about the centroid."""
    return np.array([part.mass, part.mass, part.density * part.polar_moment])
