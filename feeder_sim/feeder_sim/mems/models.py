"""Force models of the array: 'ideal' exact integrals of the field, 'array' actuator cells at a pitch."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.mems.fields import Field
from feeder_planner.mems.frame import PartFrame
from feeder_sim.mems.cellsum import CellForceSums
from feeder_sim.mems.coverage import Grid
from feeder_sim.mems.faults import NO_FAULTS, ArrayFaults

__all__ = ["IdealForces", "ArrayForces"]


class IdealForces:
    """Exact resultant force and torque of the ideal field on the part (eqs. 1-2).

    Without cells, the only faults that apply are those on the whole field (strength error, power
    loss): the exact wrench times the faults' gain, since the wrench is linear in the field.
    """

    def __init__(self) -> None:
        self.faults: ArrayFaults = NO_FAULTS

    def set_faults(self, faults: ArrayFaults) -> None:
        """Put ``faults`` in force; cell faults are refused (ValueError: the caller checks first)."""
        if faults.has_cell_faults:
            raise ValueError("the ideal force model has no cells to fail")
        self.faults = faults

    def wrench(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the field's exact wrench on the placed loops (times the faults' gain)."""
        return self._with_faults(field.wrench(loops, about))

    def wrench_at(self, field: Field, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return the field's exact wrench on the part at ``pose``, evaluated in the part frame.

        What the ideal model's every velocity evaluation costs: the part's edges are not rebuilt.
        """
        w = field.wrench_at(frame, pose)
        gain = self.faults.gain  # _with_faults, inline: this is every velocity evaluation's path
        return w if gain == 1.0 else gain * w

    def _with_faults(self, w: np.ndarray) -> np.ndarray:
        """Return the wrench times the faults' gain (the wrench is linear in the field)."""
        gain = self.faults.gain
        return w if gain == 1.0 else gain * w

    def cell_forces(self, field: Field) -> None:
        """Return None: the ideal model has no cells."""
        return None


class ArrayForces:
    """A MEMS actuator array: each cell pushes with the field's force at its centre.

    Cell forces are optionally quantised to ``directions`` actuator directions, then changed by the
    injected faults (``faults.ArrayFaults``: dead, stuck cells, strength error, power loss); force on
    a part = sum of exact covered area times cell force, torque = sum of cell force times the exact
    first moment of the covered area.
    """

    def __init__(self, nx: int, ny: int, pitch: float, directions: int = 0) -> None:
        self.grid = Grid(nx, ny, pitch)
        self.directions = int(directions)
        self.faults: ArrayFaults = NO_FAULTS
        self._field: Field | None = None
        self._forces = np.zeros((nx, ny, 2))
        self._sums: CellForceSums | None = None

    def set_faults(self, faults: ArrayFaults) -> None:
        """Put ``faults`` in force from the next evaluation on (the cached cell forces are rebuilt)."""
        self.faults = faults
        self._sums = None

    def cell_forces(self, field: Field) -> np.ndarray:
        """Return the (nx, ny, 2) force per unit area every cell exerts for this field, faults included.

        Cached per field and faults.
        """
        self._sums_for(field)
        return self._forces

    def _sums_for(self, field: Field) -> CellForceSums:
        """Return the prefix sums of this field's cell forces, computing them when the field changes."""
        if self._sums is None or field is not self._field:
            forces = field.force_density(self.grid.centers())
            if self.directions > 0:
                step = 2 * math.pi / self.directions
                angle = np.round(np.arctan2(forces[..., 1], forces[..., 0]) / step) * step
                norm = np.hypot(forces[..., 0], forces[..., 1])
                forces = norm[..., None] * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
            forces = self.faults.apply_to_cells(forces)
            self._field, self._forces = field, forces
            self._sums = CellForceSums(forces, self.grid.x_nodes, self.grid.y_nodes)
        return self._sums

    def wrench(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the sum over cells of cell force times exact covered area (first moments: torque).

        Computed from edge integrals over the cells the boundary crosses (``CellForceSums``).
        """
        return self._sums_for(field).wrench(loops, about)

    def wrench_at(self, field: Field, frame: PartFrame, pose: np.ndarray) -> np.ndarray:
        """Return ``wrench`` on the part placed at ``pose``: the cells need the placed boundary."""
        return self.wrench(field, frame.placed(pose), pose[:2])

    def wrench_by_cells(self, field: Field, loops: tuple[np.ndarray, ...], about: np.ndarray) -> np.ndarray:
        """Return the same sum from the covered area and moments of every cell (the reference).

        Uses ``Grid.cell_moments``: slower, but independent of the edge integrals.
        """
        forces = self.cell_forces(field)
        si, sj, cells = self.grid.cell_moments(loops)
        f = forces[si, sj]
        area = cells[0]
        total = (f * area[..., None]).sum(axis=(0, 1))
        arm_x = cells[1] - about[0] * area
        arm_y = cells[2] - about[1] * area
        torque = float((arm_x * f[..., 1] - arm_y * f[..., 0]).sum())
        return np.array([total[0], total[1], torque])
