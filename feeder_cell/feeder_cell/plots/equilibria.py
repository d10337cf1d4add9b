"""The equilibrium curve x*(theta) of a part with its equilibria, and the part at each stable pose."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import PathPatch
from matplotlib.path import Path as MplPath

from feeder_cell.plots.common import (
    PART_COLOUR,
    STABLE_COLOUR,
    TALL,
    UNSTABLE_COLOUR,
    length_unit,
    new_figure,
)
from feeder_planner.mems import EquilibriaResult
from feeder_planner.mems.curve import curve, pivot_translation
from feeder_planner.mems.lifted import part_edges
from feeder_planner.parts import Part

__all__ = ["CURVE_SAMPLES", "MAX_POSES", "STABLE_LABEL", "UNSTABLE_LABEL", "equilibria_figure"]

CURVE_SAMPLES = 721  # half a degree apart: smooth at README size, ~10 ms of Newton
MAX_POSES = 6  # stable poses drawn; a note says how many more there are
STABLE_LABEL = "stable equilibria"
UNSTABLE_LABEL = "unstable equilibria"


def part_patch(part: Part, x: float, y: float, theta: float, **style: object) -> PathPatch:
    """Return the part (outer loop and holes, holes left empty) placed at (x, y, theta) as a patch."""
    vertices: list[np.ndarray] = []
    codes: list[np.ndarray] = []
    for loop in part.placed(x, y, theta):
        closed = np.vstack([loop, loop[:1]])
        vertices.append(closed)
        code = np.full(len(closed), MplPath.LINETO)
        code[0], code[-1] = MplPath.MOVETO, MplPath.CLOSEPOLY
        codes.append(code)
    return PathPatch(MplPath(np.vstack(vertices), np.concatenate(codes)), **style)


def _curve_axes(ax: Axes, part: Part, result: EquilibriaResult) -> None:
    """Draw x*(theta) over one turn, the zero line and the equilibria on it."""
    edges = part_edges(part)
    theta = np.linspace(0.0, 2 * math.pi, CURVE_SAMPLES)
    points = curve(edges, part.area, result.delta, theta, pivot_translation(edges))
    scale, unit = length_unit(part.unit_scale)
    ax.plot(np.degrees(theta), points.x / scale, color=PART_COLOUR, lw=1.5, label="x*(theta)")
    ax.axhline(0.0, color="0.4", lw=0.8)
    for stable, colour, label, face in (
        (True, STABLE_COLOUR, STABLE_LABEL, STABLE_COLOUR),
        (False, UNSTABLE_COLOUR, UNSTABLE_LABEL, "white"),
    ):
        chosen = [e for e in result.equilibria if e.stable == stable]
        ax.plot(
            [math.degrees(e.theta % (2 * math.pi)) for e in chosen],
            [0.0] * len(chosen),
            ls="none",
            marker="o",
            ms=7,
            mec=colour,
            mfc=face,
            mew=1.5,
            label=f"{label} ({len(chosen)})",
            gid=label,
        )
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 45))
    ax.set_xlabel("theta (deg)")
    ax.set_ylabel(f"x* ({unit})")
    ax.set_title(
        f"{part.name}: equilibrium curve x*(theta) at delta = {result.delta:g} ({result.method} method)"
    )
    ax.legend(loc="best", fontsize="small")


def _pose_axes(ax: Axes, part: Part, x: float, y: float, theta: float) -> None:
    """Draw the part at one stable pose in the plane frame, the field centre and the constant field."""
    ax.add_patch(part_patch(part, x, y, theta, fc=PART_COLOUR, ec="k", lw=0.8, alpha=0.8))
    reach = 1.3 * part.radius + math.hypot(x, y)
    ax.plot([0], [0], marker="+", color="k", ms=8)
    ax.plot([x], [y], marker=".", color=STABLE_COLOUR)
    ax.annotate(
        "",
        xy=(0.8 * reach, -0.6 * reach),
        xytext=(0.8 * reach, -0.1 * reach),
        arrowprops={"arrowstyle": "->"},
    )
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(f"theta = {math.degrees(theta % (2 * math.pi)):.1f} deg", fontsize="small")


def equilibria_figure(part: Part, result: EquilibriaResult) -> Figure:
    """Return the figure of an equilibria result: x*(theta) with equilibria marked, and stable poses.

    Parameters
    ----------
    part
        The part the result is for (its loops are drawn and its equilibrium curve is sampled).
    result
        What ``find_equilibria(part, delta, method)`` returned.

    Returns
    -------
    Figure
        Top: x*(theta, delta) in the part file's unit over one turn with the result's equilibria on
        the zero line (filled: stable, hollow: unstable; their lines carry gid STABLE_LABEL /
        UNSTABLE_LABEL). Bottom: the part at up to MAX_POSES stable poses in the plane frame (+: the
        radial field's centre, arrow: the constant field).
    """
    figure = new_figure((TALL[0], 6.5))
    stable = list(result.stable)
    shown = stable[:MAX_POSES]
    grid = figure.add_gridspec(2, max(1, len(shown)), height_ratios=(1.6, 1.0))
    _curve_axes(figure.add_subplot(grid[0, :]), part, result)
    for column, e in enumerate(shown):
        _pose_axes(figure.add_subplot(grid[1, column]), part, e.x, e.y, e.theta)
    if len(stable) > len(shown):
        figure.text(0.99, 0.01, f"{len(stable) - len(shown)} more stable poses not drawn", ha="right")
    if not stable:
        figure.text(0.5, 0.2, "no stable equilibrium", ha="center")
    return figure
