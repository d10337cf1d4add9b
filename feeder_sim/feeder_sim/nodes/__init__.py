"""ROS 2 simulator nodes: thin rclpy adapters around the feeder_sim models."""

# Node modules are executables (their `main`), not an import surface: nothing imports them. Their console
# scripts are these entries, which hold the stop signals before the module's imports (entry_points).
from feeder_planner.entry_points import lazy_main

__all__ = ["mems_field_array_main", "throwing_arm_main", "assembly_fixture_main", "squeeze_gripper_main"]

mems_field_array_main = lazy_main(f"{__name__}.mems_field_array")
throwing_arm_main = lazy_main(f"{__name__}.throwing_arm")
assembly_fixture_main = lazy_main(f"{__name__}.assembly_fixture")
squeeze_gripper_main = lazy_main(f"{__name__}.squeeze_gripper")
