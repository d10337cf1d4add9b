"""Fidelity models of the MEMS field array: ideal (exact integrals), array (cells), dynamic (pymunk).

The public surface the simulator node, the benchmark and the tests use. Importing it does not load
pymunk: only a 'dynamic' scene of several parts does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from feeder_planner.lazy import lazy_exports

if TYPE_CHECKING:  # the package's names; each module is imported on first use (feeder_planner.lazy)
    from feeder_sim.mems.bodies import FIDELITIES, Body, Fidelity, ForceModel, check_fidelity
    from feeder_sim.mems.coverage import Grid
    from feeder_sim.mems.models import ArrayForces, IdealForces
    from feeder_sim.mems.scene import Scene, random_poses

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "FIDELITIES",
    "Fidelity",
    "check_fidelity",
    "Body",
    "ForceModel",
    "Scene",
    "random_poses",
    "Grid",
    "ArrayForces",
    "IdealForces",
]
