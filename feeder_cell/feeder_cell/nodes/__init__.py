"""Nodes that serve the whole cell rather than one device (the cell clock)."""
