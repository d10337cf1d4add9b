"""The cell as the ROS 2 simulation standard sees it (``simulation_interfaces``), ROS-free.

``results`` (the standard's result codes as one error type), ``control`` (simulation states, steps and
reset scopes mapped onto the cell clock and the devices' lifecycles), ``entities`` (what is in the cell,
named stably, and the standard's filters) and ``spawning`` (what SpawnEntity and SetEntityState accept).
The node ``feeder_cell.nodes.cell_simulation`` only wires them to services; docs/cell.md, "Driving the
cell with simulation_interfaces", is the user's view.
"""
