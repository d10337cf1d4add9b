"""Subcommands of the assembly planner (registered by its owner; empty until then)."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this module's subcommands to the feeder parser."""
