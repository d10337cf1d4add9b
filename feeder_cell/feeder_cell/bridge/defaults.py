"""Where ``feeder bridge`` listens unless told otherwise: this machine only, Foxglove's usual port."""

DEFAULT_ADDRESS = "127.0.0.1"
DEFAULT_PORT = 8765
