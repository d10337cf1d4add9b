"""ROS 2 simulator nodes: thin rclpy adapters around the feeder_sim models."""

# Node modules are executables (their `main`), not an import surface: nothing imports them.
__all__: list[str] = []
