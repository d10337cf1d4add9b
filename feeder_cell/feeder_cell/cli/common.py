"""Shared pieces of the ``feeder`` subcommands: argument types and output."""

from __future__ import annotations

import argparse
import json
import math
import sys
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
