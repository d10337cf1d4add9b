"""Planners and the exact mechanics behind them (numpy/scipy only; no rclpy at import)."""
