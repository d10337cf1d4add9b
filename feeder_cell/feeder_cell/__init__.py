"""What serves the whole cell rather than one device: the ``feeder`` command, scenes, bags, doctor."""

# The subpackages are the public surface; each lists its own names in its __all__.
__all__: list[str] = []
