"""The ``feeder`` command: one module per group of subcommands, each with ``register(subparsers)``."""
