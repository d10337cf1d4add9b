"""The simulation node's parameters and the constants it is wired with (docs/cell.md, docs/nodes.md).

``feeder_cell.nodes.cell_simulation`` declares ``PARAMETERS`` at start-up and re-exports these names, so
tools/nodes_doc.py finds the parameter table where it finds every node's: in the node module.
"""

from __future__ import annotations

from dataclasses import dataclass

from feeder_planner.parameter_specs import param, positive, specs_of

__all__ = ["SimulationParameters", "PARAMETERS", "STEPPING", "CLOCK_HARDWARE_ID"]


@dataclass(frozen=True)
class SimulationParameters:
    """The simulation node's parameters (docs/cell.md); `feeder launch` sets the scene's devices."""

    clock_node: str = param("/cell_clock", "the cell clock node it pauses, resumes and steps", read_only=True)
    quantum: float = param(
        0.1, "cell seconds per step: the cell clock's lockstep quantum", positive, read_only=True
    )
    mems_field_arrays: list[str] = param(
        [""], "fully qualified names of the scene's MEMS arrays", read_only=True
    )
    throwing_arms: list[str] = param(
        [""], "fully qualified names of the scene's throwing arms", read_only=True
    )
    assembly_fixtures: list[str] = param(
        [""], "fully qualified names of the scene's fixtures", read_only=True
    )
    part_directories: list[str] = param(
        [""],
        "directories whose part files GetSpawnables lists (feeder launch: those the scene names)",
        read_only=True,
    )
    call_timeout: float = param(
        30.0,
        "wall seconds a device or the clock may take to be discovered, and then to answer a call",
        positive,
        read_only=True,
    )


PARAMETERS = specs_of(SimulationParameters)
STEPPING = ("step_simulation", "simulate_steps")  # the requests a SetSimulationState interrupts
CLOCK_HARDWARE_ID = "sim:cell_clock"  # the hardware_id of the cell clock's lockstep status
