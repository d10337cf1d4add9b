"""What serves the whole cell rather than one device: the ``feeder`` command, scenes, bags, doctor."""
