"""Nodes that serve the whole cell rather than one device (the cell clock)."""

# Node modules are executables (their `main`), not an import surface: nothing imports them.
__all__: list[str] = []
