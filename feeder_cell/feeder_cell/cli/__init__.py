"""The ``feeder`` command: one module per group of subcommands, each with ``register(subparsers)``."""

__all__ = ["SUBCOMMAND_MODULES"]

# The subcommand modules, in the order `feeder --help` lists them (cli.main imports each for its parser).
SUBCOMMAND_MODULES = (
    "feeder_cell.cli.doctor",
    "feeder_cell.cli.run",
    "feeder_cell.cli.bag",
    "feeder_cell.cli.play",
    "feeder_cell.cli.bag_plot",
    "feeder_cell.cli.launch",
    "feeder_cell.cli.lifecycle",
    "feeder_cell.cli.clock",
    "feeder_cell.cli.calls",
    "feeder_cell.cli.equilibria",
    "feeder_cell.cli.part_info",
    "feeder_cell.cli.throwing",
    "feeder_cell.cli.squeeze",
    "feeder_cell.cli.assembly",
    "feeder_cell.cli.bridge",
    "feeder_cell.cli.experiment",
)
