"""Simulated feeder devices: fidelity models (pure numpy/scipy/pymunk) and their ROS 2 nodes."""

# The subpackages are the public surface; each lists its own names in its __all__.
__all__: list[str] = []
