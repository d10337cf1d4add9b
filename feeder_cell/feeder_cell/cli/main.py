"""Entry point of the ``feeder`` command: builds the parser and maps errors to exit codes."""

from __future__ import annotations

import argparse
import importlib
import sys
from typing import NoReturn, Sequence

from feeder_cell.cli import SUBCOMMAND_MODULES
from feeder_planner.errors import FeederError, InputError, SolverError

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_NOT_CERTIFIED = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as a shell reports a command ended by Ctrl-C
# An argument error quotes the user's text: at most this much of it, so that a hostile flag stays one line.
MAX_ERROR_CHARS = 300


class FeederArgumentParser(argparse.ArgumentParser):
    """Parse ``feeder`` arguments with the contract's error shape: exit 2, one line for a bad value."""

    def error(self, message: str) -> NoReturn:
        """Print the error as ONE line on stderr (the contract's shape, no usage block) and exit with 2."""
        line = " ".join(message.split())  # argparse messages may span lines (a long list of choices)
        sys.stderr.write(f"{self.prog}: error: {line[:MAX_ERROR_CHARS]} (for usage: {self.prog} --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


def build_parser() -> argparse.ArgumentParser:
    """Build the ``feeder`` parser with every subcommand."""
    parser = FeederArgumentParser(
        prog="feeder",
        description="Plan for and run emulated sensorless parts feeders (ROS 2 Jazzy). "
        "Units are SI in JSON output; lengths on the command line are in the part file's unit; "
        "angles are radians unless suffixed 'deg'.",
    )
    subparsers = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=FeederArgumentParser
    )
    for module_name in SUBCOMMAND_MODULES:
        importlib.import_module(module_name).register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one ``feeder`` subcommand; return its exit status (1 failed, 2 bad input, 3 not certified)."""
    try:
        parser = build_parser()
    except KeyboardInterrupt:  # Ctrl-C while the subcommands' modules are imported
        sys.stderr.write("feeder: interrupted\n")
        return EXIT_INTERRUPTED
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or EXIT_OK)
    except InputError as error:
        sys.stderr.write(f"feeder {args.command}: {error}\n")
        return EXIT_BAD_INPUT
    except SolverError as error:
        sys.stderr.write(f"feeder {args.command}: not certified: {error}\n")
        return EXIT_NOT_CERTIFIED
    except FeederError as error:  # a device or node refused (a lifecycle transition, a start-up)
        sys.stderr.write(f"feeder {args.command}: {error}\n")
        return EXIT_FAILED
    except KeyboardInterrupt:  # Ctrl-C: one line and the shell's status for SIGINT, not a traceback
        sys.stderr.write(f"feeder {args.command}: interrupted\n")
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
