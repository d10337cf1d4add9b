"""Planners and the exact mechanics behind them (numpy/scipy only; no rclpy at import)."""

# The subpackages are the public surface; each lists its own names in its __all__.
__all__: list[str] = []
