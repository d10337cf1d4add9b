"""Force models of the array: 'ideal' exact integrals of the field, 'array' actuator cells at a pitch."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.mems.fields import Field
from feeder_sim.mems.cellsum import CellForceSums
from feeder_sim.mems.coverage import Grid


class IdealForces:
    """Exact resultant force and torque of the ideal field on the part (eqs. 1-2)."""

    name = "ideal"

    def wrench(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        return field.wrench(loops, about)

    def cell_forces(self, field: Field) -> None:
        return None


class ArrayForces:
    """A MEMS actuator array: each cell pushes with the field's force at its centre, optionally
    quantised to ``directions`` actuator directions; force on a part = sum of exact covered area
    times cell force, torque = sum of cell force times the exact first moment of the covered area.
    """

    name = "array"

    def __init__(self, nx: int, ny: int, pitch: float, directions: int = 0) -> None:
        self.grid = Grid(nx, ny, pitch)
        self.directions = int(directions)
        self._field: Field | None = None
        self._forces = np.zeros((nx, ny, 2))
        self._sums: CellForceSums | None = None

    def cell_forces(self, field: Field) -> np.ndarray:
        """(nx, ny, 2) force per unit area of every cell for this field (cached per field)."""
        if field is not self._field:
            forces = field.force_density(self.grid.centers())
            if self.directions > 0:
                step = 2 * math.pi / self.directions
                angle = np.round(np.arctan2(forces[..., 1], forces[..., 0]) / step) * step
                norm = np.hypot(forces[..., 0], forces[..., 1])
                forces = norm[..., None] * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
            self._field, self._forces = field, forces
            self._sums = CellForceSums(forces, self.grid.x_nodes, self.grid.y_nodes)
        return self._forces

    def wrench(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Sum over cells of cell force times exact covered area (and first moments for the torque),
        from edge integrals over the cells the boundary crosses (``CellForceSums``).
        """
        self.cell_forces(field)
        return self._sums.wrench(loops, about)

    def wrench_by_cells(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Reference: the same sum from the covered area and moments of every cell (``Grid.cell_moments``)."""
        forces = self.cell_forces(field)
        si, sj, cells = self.grid.cell_moments(loops)
        f = forces[si, sj]
        area = cells[0]
        total = (f * area[..., None]).sum(axis=(0, 1))
        arm_x = cells[1] - about[0] * area
        arm_y = cells[2] - about[1] * area
        torque = float((arm_x * f[..., 1] - arm_y * f[..., 0]).sum())
        return np.array([total[0], total[1], torque])
