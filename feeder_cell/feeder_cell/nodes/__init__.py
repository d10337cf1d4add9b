"""Nodes that serve the whole cell rather than one device (the cell clock)."""

# Node modules are executables (their `main`), not an import surface: nothing imports them. Their console
# scripts are these entries, which hold the stop signals before the module's imports (entry_points).
from feeder_planner.entry_points import lazy_main

__all__ = ["cell_clock_main", "cell_controller_main", "cell_simulation_main", "opcua_gateway_main"]

cell_clock_main = lazy_main(f"{__name__}.cell_clock")
cell_controller_main = lazy_main(f"{__name__}.cell_controller")
cell_simulation_main = lazy_main(f"{__name__}.cell_simulation")
opcua_gateway_main = lazy_main(f"{__name__}.opcua_gateway")
