"""The ``--plot FILE`` flag of the planner subcommands: checked while parsing, drawn after the result.

matplotlib is imported only when a plot is asked for, so the subcommands stay as quick without it.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

from feeder_cell.plots.paths import check_plot_path
from feeder_planner.errors import InputError

__all__ = ["PLOT_KINDS", "add_plot_flag", "plot_path", "write_plot"]

# Plot kind -> (module, figure function): imported only when drawn, so that matplotlib stays unloaded.
PLOT_KINDS = {
    "equilibria": ("feeder_cell.plots.equilibria", "equilibria_figure"),
    "limit-set": ("feeder_cell.plots.limit_set", "limit_set_figure"),
    "throw-design": ("feeder_cell.plots.throw_design", "design_figure"),
    "stable-region": ("feeder_cell.plots.stable_region", "region_figure"),
    "check-stability": ("feeder_cell.plots.stability", "stability_figure"),
    "timeline": ("feeder_cell.plots.timeline", "timeline_figure"),
}


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


def write_plot(args: argparse.Namespace, kind: str, *objects: object, **options: object) -> Path | None:
    """Draw the figure of ``kind`` and write it if ``--plot`` was given; return its path (None without).

    ``objects`` and ``options`` go to the kind's figure function (PLOT_KINDS), e.g. the part and the
    result for "equilibria". Without --json the path is printed on stdout after the summary
    ("plot: PATH"); with --json stdout keeps its one JSON object.
    """
    if getattr(args, "plot", None) is None:
        return None
    from feeder_cell.plots.common import write_figure

    module, function = PLOT_KINDS[kind]
    draw = getattr(importlib.import_module(module), function)
    path = write_figure(draw(*objects, **options), args.plot)
    if not getattr(args, "json", False):
        sys.stdout.write(f"plot: {path}\n")
    return path
