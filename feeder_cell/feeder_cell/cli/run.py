"""``feeder run``: start a node executable the way ``ros2 run`` finds it (through the ament index)."""

from __future__ import annotations

import argparse
import os

from feeder_cell.launcher import resolve_executable


def _run(args: argparse.Namespace) -> int:
    path = resolve_executable(args.package, args.executable)
    # exec, not a child: the caller's pid is the node's pid, so ending it by pid ends the node.
    os.execv(str(path), [str(path), *args.node_args])
    return 0  # not reached


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the ``feeder`` parser."""
    parser = subparsers.add_parser(
        "run",
        help="run a node executable of a package (like 'ros2 run')",
        description="Resolve PACKAGE's EXECUTABLE through the ament index (PREFIX/lib/PACKAGE/EXECUTABLE, "
        "as 'ros2 run' does) and replace this process with it. Everything after EXECUTABLE, "
        "including --ros-args, is passed to the node.",
    )
    parser.add_argument("package")
    parser.add_argument("executable")
    parser.add_argument(
        "node_args", nargs=argparse.REMAINDER, help="arguments for the node, e.g. --ros-args -p rate:=50.0"
    )
    parser.set_defaults(handler=_run)
