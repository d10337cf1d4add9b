"""The ``--plot FILE`` flag of the planner subcommands: checked while parsing, drawn after the result.

matplotlib is imported only when a plot is asked for, so the subcommands stay as quick without it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from feeder_cell.plots.paths import check_plot_path
from feeder_planner.errors import InputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["add_plot_flag", "plot_path", "write_plot"]


def plot_path(text: str) -> Path:
    """Argparse type of ``--plot``: a .png or .svg file name in an existing folder."""
    try:
        return check_plot_path(text)
    except InputError as error:
        raise argparse.ArgumentTypeError(error.problem) from None


def add_plot_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--plot FILE`` (PNG or SVG by the extension) to a subcommand's parser."""
    parser.add_argument(
        "--plot",
        type=plot_path,
        default=None,
        metavar="FILE",
        help="also draw the result into FILE; the format comes from the extension, .png or .svg",
    )


def write_plot(args: argparse.Namespace, draw: Callable[[], Figure]) -> Path | None:
    """Draw and write the figure if ``--plot`` was given; return its path (None without --plot).

    Without --json the path is printed on stdout after the summary ("plot: PATH"); with --json stdout
    keeps its one JSON object.
    """
    if getattr(args, "plot", None) is None:
        return None
    from feeder_cell.plots.common import write_figure

    path = write_figure(draw(), args.plot)
    if not getattr(args, "json", False):
        sys.stdout.write(f"plot: {path}\n")
    return path
