"""The ``feeder`` command: one module per group of subcommands, each with ``register(subparsers)``."""

__all__ = ["SUBCOMMANDS", "modules_for"]

# Each subcommand module and the commands its register() adds, in the order `feeder --help` lists them.
# `feeder COMMAND` imports only COMMAND's module: every module's imports (the mechanics, rclpy, scipy) cost
# about 0.6 CPU s together, paid by each short command and each test that runs one. A test checks that
# this table names exactly what each module registers.
SUBCOMMANDS: dict[str, tuple[str, ...]] = {
    "feeder_cell.cli.doctor": ("doctor",),
    "feeder_cell.cli.run": ("run",),
    "feeder_cell.cli.bag": ("record", "bag-info", "bag-reindex", "bag-compare", "bag-convert"),
    "feeder_cell.cli.play": ("play",),
    "feeder_cell.cli.bag_plot": ("bag-plot",),
    "feeder_cell.cli.launch": ("launch",),
    "feeder_cell.cli.lifecycle": ("lifecycle",),
    "feeder_cell.cli.clock": ("clock",),
    "feeder_cell.cli.calls": ("call", "send-goal"),
    "feeder_cell.cli.equilibria": ("equilibria",),
    "feeder_cell.cli.part_info": ("part-info",),
    "feeder_cell.cli.throwing": ("throw", "limit-set", "throw-design"),
    "feeder_cell.cli.squeeze": ("squeeze-plan",),
    "feeder_cell.cli.assembly": ("stable-region", "check-stability"),
    "feeder_cell.cli.bridge": ("bridge",),
    "feeder_cell.cli.experiment": ("experiment",),
}


def modules_for(command: str | None) -> tuple[str, ...]:
    """Return the module that registers ``command``, or every module (for --help and unknown commands)."""
    owners = tuple(module for module, commands in SUBCOMMANDS.items() if command in commands)
    return owners or tuple(SUBCOMMANDS)
