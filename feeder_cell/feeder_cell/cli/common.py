"""Shared pieces of the ``feeder`` subcommands: argument types and output."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path
from typing import Any, Callable

from feeder_planner.errors import InputError
from feeder_planner.units import parse_angle


def finite_float(text: str) -> float:
    """Argparse type: a finite float (NaN and inf are refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def angle(text: str) -> float:
    """Argparse type: radians, or degrees with a 'deg' suffix."""
    try:
        return parse_angle(text, "angle")
    except InputError as error:
        raise argparse.ArgumentTypeError(error.problem) from None


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    """Add the contract's ``--json`` flag (one JSON object on stdout)."""
    parser.add_argument(
        "--json", action="store_true", help="print exactly one JSON object on stdout (SI units)"
    )


def emit(args: argparse.Namespace, result: dict[str, Any], summary: Callable[[dict[str, Any]], str]) -> None:
    """Print ``result`` as one JSON object with --json, else the human summary."""
    if getattr(args, "json", False):
        sys.stdout.write(json.dumps(result, allow_nan=False) + "\n")
    else:
        sys.stdout.write(summary(result).rstrip("\n") + "\n")


def output_directory(path: str | Path, field: str, must_be_new: bool = False) -> Path:
    """Return ``path`` as a directory the command may create or write to, else an InputError naming ``field``.

    Checked before any work: an existing path that is not a directory, or an ancestor that is a file (where
    a later mkdir would fail with NotADirectoryError), or an unwritable parent. ``must_be_new`` also
    refuses an existing directory (a bag is never overwritten).

    Parameters
    ----------
    path
        The directory named on the command line.
    field
        The flag or argument named in the error, e.g. ``output`` or ``--log-dir``.
    must_be_new
        Refuse a path that already exists.

    Returns
    -------
    Path
        ``path`` as a Path.
    """
    target = Path(path)
    if target.exists() or target.is_symlink():
        if must_be_new:
            raise InputError(field, f"{str(target)[:200]} already exists; it is never overwritten")
        if not target.is_dir():
            raise InputError(field, f"{str(target)[:200]} exists and is not a directory")
        return target
    ancestor = target.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(
            field, f"cannot create {str(target)[:200]}: {str(ancestor)[:200]} is not a directory"
        )
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise InputError(field, f"cannot create {str(target)[:200]}: {str(ancestor)[:200]} is not writable")
    return target
