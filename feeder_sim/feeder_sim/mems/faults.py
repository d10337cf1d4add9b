"""Injected faults of the MEMS field array: what its cells really push with, ROS-free.

A controller's error handling is tested by injecting faults into the simulated array. Each fault acts
on the force model, never on the mechanics of the part:

* ``dead_cells``: the chosen cells push with no force at all;
* ``stuck_cells``: the chosen cells push in one fixed direction ``angle`` (rad, plane frame) with the
  magnitude the programmed field has at their centre, whatever the program asks;
* ``field_strength_error``: every cell force is scaled by ``1 + e`` (a miscalibrated drive);
* ``power_loss``: no field at all.

Cells are numbered row-major, ``i * ny + j`` for cell (i, j), as in feeder_msgs/MemsCellForces. They
are given explicitly or drawn as a fraction of the array with a seeded numpy Generator, so a run with
a fault is as deterministic as one without. Cell faults need cells: the ``array`` fidelity; the
``ideal`` and ``dynamic`` fidelities integrate the field exactly and accept only the strength error and
the power loss. ``ArrayFaults`` is immutable: a force model is given a new one when faults change.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Final, Literal, get_args

import numpy as np

from feeder_planner.errors import InputError

__all__ = [
    "FaultName",
    "FAULT_NAMES",
    "CELL_FAULTS",
    "ArrayFaults",
    "NO_FAULTS",
    "draw_cells",
    "check_cells",
    "check_strength_error",
    "check_angle",
]

FaultName = Literal["dead_cells", "stuck_cells", "field_strength_error", "power_loss"]
FAULT_NAMES: tuple[FaultName, ...] = get_args(FaultName)
# The faults that act on individual cells and so need the 'array' fidelity.
CELL_FAULTS: Final = ("dead_cells", "stuck_cells")

# Separate random streams per cell fault: the same seed must not make the dead and the stuck cells
# the same cells.
_STREAM: Final = {"dead_cells": 0, "stuck_cells": 1}


def draw_cells(name: str, nx: int, ny: int, fraction: float, seed: int) -> tuple[int, ...]:
    """Return ``round(fraction * nx * ny)`` distinct cells (sorted), drawn for ``seed``.

    ``fraction`` must be in (0, 1]; the draw depends on the fault's name, the array size and the seed
    only. Raises InputError naming ``value`` otherwise.
    """
    if not (isinstance(fraction, (int, float)) and math.isfinite(fraction) and 0 < fraction <= 1):
        raise InputError(
            "value", f"{name}: a fraction of the cells in (0, 1] (or give indices), got {fraction!r}"
        )
    total = nx * ny
    count = max(1, int(round(fraction * total)))
    rng = np.random.default_rng((int(seed), _STREAM.get(name, 2)))
    return tuple(int(i) for i in np.sort(rng.choice(total, size=min(count, total), replace=False)))


def check_cells(indices: Sequence[int], nx: int, ny: int) -> tuple[int, ...]:
    """Return the distinct cell indices (sorted); raise InputError naming ``indices[k]`` if off the array."""
    total = nx * ny
    for k, index in enumerate(indices):
        if not 0 <= int(index) < total:
            raise InputError(
                f"indices[{k}]",
                f"cell {index} is not on the {nx} x {ny} array (0 .. {total - 1}, cell (i, j) is i * ny + j)",
            )
    return tuple(sorted({int(i) for i in indices}))


def check_strength_error(value: float) -> float:
    """Return the relative error e (finite, nonzero, > -1); raise InputError naming ``value``."""
    if not (math.isfinite(value) and value > -1.0 and value != 0.0):
        raise InputError(
            "value",
            f"field_strength_error: the relative error e (cell forces scaled by 1 + e), finite, nonzero "
            f"and > -1, got {value!r}",
        )
    return float(value)


def check_angle(angle: float) -> float:
    """Return a finite force direction (rad); raise InputError naming ``angle``."""
    if not math.isfinite(angle):
        raise InputError("angle", f"stuck_cells: the force direction (rad) must be finite, got {angle!r}")
    return float(angle)


@dataclass(frozen=True)
class ArrayFaults:
    """The faults in force on one array (empty: a healthy array)."""

    dead: tuple[int, ...] = ()  # cells with no force (row-major indices)
    stuck: tuple[int, ...] = ()  # cells pushing in direction stuck_angle at the field's magnitude
    stuck_angle: float = 0.0  # rad, plane frame
    strength_error: float = 0.0  # e: every cell force times 1 + e
    power_loss: bool = False  # no field at all

    @property
    def gain(self) -> float:
        """Return the factor on every force: 0 without power, else 1 + e."""
        return 0.0 if self.power_loss else 1.0 + self.strength_error

    @property
    def has_cell_faults(self) -> bool:
        """Whether any cell is dead or stuck (faults that need the array's cells)."""
        return bool(self.dead or self.stuck)

    @property
    def healthy(self) -> bool:
        """Whether no fault is in force."""
        return self == NO_FAULTS

    def apply_to_cells(self, forces: np.ndarray) -> np.ndarray:
        """Return what (nx, ny, 2) commanded cell forces become under these faults (``forces`` if none).

        Stuck cells push at the commanded magnitude in the stuck direction; dead cells (a cell both
        dead and stuck is dead) push with nothing; then every force is scaled by the gain.
        """
        if self.healthy:
            return forces
        out = np.array(forces, float, copy=True)
        flat = out.reshape(-1, 2)
        if self.stuck:
            cells = np.asarray(self.stuck)
            magnitude = np.hypot(flat[cells, 0], flat[cells, 1])
            flat[cells, 0] = magnitude * math.cos(self.stuck_angle)
            flat[cells, 1] = magnitude * math.sin(self.stuck_angle)
        if self.dead:
            flat[np.asarray(self.dead)] = 0.0
        out *= self.gain
        return out

    def with_fault(
        self,
        name: str,
        *,
        value: float = 0.0,
        indices: Sequence[int] = (),
        angle: float = 0.0,
        seed: int = 0,
        cells: tuple[int, int] | None = None,
        fidelity: str = "array",
    ) -> ArrayFaults:
        """Return these faults with ``name`` (re)set from a request's magnitudes.

        ``cells`` is the array's (nx, ny); ``fidelity`` the scene's, since cell faults need the
        'array' fidelity. Raises InputError naming ``fault``, ``value``, ``indices`` or ``angle``.
        """
        if name in CELL_FAULTS:
            if fidelity != "array" or cells is None:
                raise InputError(
                    "fault",
                    f"{name} acts on the array's cells and needs fidelity 'array'; this array runs "
                    f"{fidelity!r} (exact field integrals, no cells): only field_strength_error and "
                    "power_loss apply",
                )
            nx, ny = cells
            if indices:
                if value != 0.0:
                    raise InputError("value", f"{name}: give a fraction of the cells or indices, not both")
                chosen = check_cells(indices, nx, ny)
            else:
                chosen = draw_cells(name, nx, ny, value, seed)
            if name == "dead_cells":
                return replace(self, dead=chosen)
            return replace(self, stuck=chosen, stuck_angle=check_angle(angle))
        if name == "field_strength_error":
            return replace(self, strength_error=check_strength_error(value))
        if name == "power_loss":
            return replace(self, power_loss=True)
        raise InputError("fault", f"unknown fault {name!r} (known: {', '.join(FAULT_NAMES)})")

    def without(self, name: str) -> ArrayFaults:
        """Return these faults with ``name`` cleared (an unknown or inactive name changes nothing)."""
        if name == "dead_cells":
            return replace(self, dead=())
        if name == "stuck_cells":
            return replace(self, stuck=(), stuck_angle=0.0)
        if name == "field_strength_error":
            return replace(self, strength_error=0.0)
        if name == "power_loss":
            return replace(self, power_loss=False)
        return self


NO_FAULTS: Final = ArrayFaults()
