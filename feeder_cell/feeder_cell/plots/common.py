"""What every plot shares: the headless figure, the output format from the extension, sizes, colours."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from feeder_cell.plots.paths import PLOT_FORMATS, check_plot_path
from feeder_planner.errors import InputError
from feeder_planner.units import LENGTH_UNITS

__all__ = [
    "WIDE",
    "SQUARE",
    "TALL",
    "DPI",
    "STABLE_COLOUR",
    "UNSTABLE_COLOUR",
    "PART_COLOUR",
    "HIGHLIGHT_COLOUR",
    "SHADE_COLOUR",
    "edge_colour",
    "length_unit",
    "new_figure",
    "write_figure",
]

# Figure sizes in inches at DPI: 8 x 4.5 in at 100 dpi is an 800 x 450 px PNG, small enough for a README.
WIDE = (8.0, 4.5)
SQUARE = (6.0, 6.0)
TALL = (8.0, 9.0)
DPI = 100

STABLE_COLOUR = "#1b7837"
UNSTABLE_COLOUR = "#c51b7d"
PART_COLOUR = "#4393c3"
HIGHLIGHT_COLOUR = "#d6604d"
SHADE_COLOUR = "#fdb863"
# Colour-blind-safe qualitative palette (Okabe-Ito) for hull edges and devices.
_PALETTE = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000")


def edge_colour(index: int) -> str:
    """Return the colour of hull edge (or device, or part) ``index``, the same in every plot."""
    return _PALETTE[index % len(_PALETTE)]


def length_unit(unit_scale: float) -> tuple[float, str]:
    """Return (metres per unit, unit name) of a file's length unit, so plots read like the file."""
    name = next((n for n, s in LENGTH_UNITS.items() if s == unit_scale), None)
    return (unit_scale, name) if name is not None else (1.0, "m")


def new_figure(size: tuple[float, float] = WIDE) -> Figure:
    """Return an empty figure drawn by the Agg canvas (no pyplot, no display, no global state)."""
    return Figure(figsize=size, dpi=DPI, layout="constrained")


def write_figure(figure: Figure, path: str | Path, flag: str = "--plot") -> Path:
    """Save ``figure`` to ``path`` in the format of its extension; return the path written.

    A failing write (no permission, disk full) is an InputError naming ``flag``, never a traceback.
    """
    target = check_plot_path(path, flag)
    try:
        figure.savefig(target, format=PLOT_FORMATS[target.suffix.lower()], dpi=DPI)
    except OSError as error:
        raise InputError(flag, f"cannot write {target}: {error.strerror or error}") from None
    return target
