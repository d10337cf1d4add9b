"""Entry point of the ``feeder`` command: builds the parser and maps errors to exit codes."""

from __future__ import annotations

if __name__ == "__main__":  # the program (python -m): Ctrl-C remembered from here until main() takes it
    from feeder_cell.cli.ctrl_c import remember_ctrl_c

    remember_ctrl_c()

import argparse
import atexit
import importlib
import os
import signal
import sys
from typing import NoReturn, Sequence

from feeder_cell.cli import modules_for
from feeder_cell.cli.ctrl_c import check_ctrl_c, ctrl_c_requested, take_ctrl_c
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


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the ``feeder`` parser: with ``command``'s subcommand module only, or with every subcommand."""
    parser = FeederArgumentParser(
        prog="feeder",
        description="Plan for and run emulated sensorless parts feeders (ROS 2 Jazzy). "
        "Units are SI in JSON output; lengths on the command line are in the part file's unit; "
        "angles are radians unless suffixed 'deg'.",
    )
    subparsers = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", parser_class=FeederArgumentParser
    )
    for module_name in modules_for(command):
        importlib.import_module(module_name).register(subparsers)
    return parser


def _interrupted(prefix: str) -> int:
    """Say that Ctrl-C ended the command, in one line; return the shell's status for SIGINT."""
    sys.stderr.write(f"{prefix}: interrupted\n")
    return EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None) -> int:
    """Run one ``feeder`` subcommand; return its exit status (1 failed, 2 bad input, 3 not certified)."""
    take_ctrl_c()
    words = list(sys.argv[1:] if argv is None else argv)
    try:
        check_ctrl_c()  # one that came while this module was imported
        # The top-level parser has no option that takes a value, so the first word is the command.
        parser = build_parser(words[0] if words and not words[0].startswith("-") else None)
        args = parser.parse_args(words)
    except KeyboardInterrupt:  # Ctrl-C while the subcommands' modules are imported or the words parsed
        return _interrupted("feeder")
    except Exception:
        if not ctrl_c_requested():
            raise
        return _interrupted("feeder")  # its KeyboardInterrupt came out wrapped (ctrl_c.py)
    try:
        code = int(args.handler(args) or EXIT_OK)
        if code != EXIT_INTERRUPTED:
            check_ctrl_c()  # a Ctrl-C whose KeyboardInterrupt was swallowed still ends the command as one
        return code
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
        return _interrupted(f"feeder {args.command}")
    except Exception:
        if not ctrl_c_requested():
            raise
        return _interrupted(f"feeder {args.command}")  # wrapped, as above


def run() -> NoReturn:
    """Run the ``feeder`` program: :func:`main`, then exit with its status (130 after Ctrl-C, exactly).

    CPython ends a process by SIGINT itself (status -2, whatever ``sys.exit`` said) once a
    KeyboardInterrupt has escaped any code it ran through its ``PyRun_*`` entry points, even when an
    outer ``except`` caught it afterwards: an import that Ctrl-C interrupted did that, and 1 in 3
    interrupted commands ended -2. After Ctrl-C the exit handlers run and the process exits with 130
    directly; every other status goes through ``sys.exit``.
    """
    code = main()
    if code == EXIT_INTERRUPTED:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the status is decided: a late Ctrl-C changes nothing
        sys.stdout.flush()
        sys.stderr.flush()
        atexit._run_exitfuncs()  # what the interpreter's own exit would run (dask, logging, temp dirs)
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
