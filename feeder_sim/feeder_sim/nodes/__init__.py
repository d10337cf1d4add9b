"""ROS 2 simulator nodes: thin rclpy adapters around the feeder_sim models."""

# Node modules are executables (their `main`), not an import surface: nothing imports them. The console
# script of node module NAME is the entry NAME_main here, made on demand (feeder_planner.entry_points:
# it holds the stop signals before the module's imports), so a new node module adds no line.
from __future__ import annotations

from typing import Callable

from feeder_planner.entry_points import node_main


def __getattr__(attribute: str) -> Callable[[], None]:
    return node_main(__name__, attribute)
