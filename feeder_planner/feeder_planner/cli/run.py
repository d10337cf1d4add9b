"""``feeder run``: start a node executable the way ``ros2 run`` finds it (through the ament index)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from feeder_planner.errors import InputError


def resolve_executable(package: str, executable: str) -> Path:
    """``<prefix of package>/lib/<package>/<executable>``, the layout ``ros2 run`` looks up."""
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix

    try:
        prefix = Path(get_package_prefix(package))
    except (PackageNotFoundError, ValueError):
        raise InputError("package", f"package {package!r} not found in the ament index "
                                    "(did you run 'make setup' and 'source env.sh'?)") from None
    lib_dir = prefix / "lib" / package
    candidate = lib_dir / executable
    if not (candidate.is_file() and os.access(candidate, os.X_OK)):
        available = sorted(p.name for p in lib_dir.iterdir() if p.is_file() and os.access(p, os.X_OK)) \
            if lib_dir.is_dir() else []
        raise InputError("executable", f"no executable {executable!r} in package {package!r} "
                                       f"(available: {', '.join(available) or 'none'})")
    return candidate


def _run(args: argparse.Namespace) -> int:
    path = resolve_executable(args.package, args.executable)
    # exec, not a child: the caller's pid is the node's pid, so ending it by pid ends the node.
    os.execv(str(path), [str(path), *args.node_args])
    return 0  # not reached


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "run", help="run a node executable of a package (like 'ros2 run')",
        description="Resolve PACKAGE's EXECUTABLE through the ament index (PREFIX/lib/PACKAGE/EXECUTABLE, "
                    "as 'ros2 run' does) and replace this process with it. Everything after EXECUTABLE, "
                    "including --ros-args, is passed to the node.")
    parser.add_argument("package")
    parser.add_argument("executable")
    parser.add_argument("node_args", nargs=argparse.REMAINDER, help="arguments for the node, e.g. --ros-args -p rate:=50.0")
    parser.set_defaults(handler=_run)
