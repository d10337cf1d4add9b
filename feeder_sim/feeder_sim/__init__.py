"""Simulated feeder devices: fidelity models (pure numpy/scipy/pymunk) and their ROS 2 nodes."""
