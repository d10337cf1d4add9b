"""ROS 2 planner nodes: thin rclpy adapters around the feeder_planner mechanics."""

# Node modules are executables (their `main`), not an import surface: nothing imports them. Their console
# scripts are these entries, which hold the stop signals before the module's imports (entry_points).
from feeder_planner.entry_points import lazy_main

__all__ = [
    "field_equilibria_planner_main",
    "throw_planner_main",
    "stable_region_planner_main",
    "squeeze_planner_main",
]

field_equilibria_planner_main = lazy_main(f"{__name__}.field_equilibria_planner")
throw_planner_main = lazy_main(f"{__name__}.throw_planner")
stable_region_planner_main = lazy_main(f"{__name__}.stable_region_planner")
squeeze_planner_main = lazy_main(f"{__name__}.squeeze_planner")
