"""ROS 2 planner nodes: thin rclpy adapters around the feeder_planner mechanics."""

# Node modules are executables (their `main`), not an import surface: nothing imports them.
__all__: list[str] = []
