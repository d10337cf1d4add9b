"""A throwing-arm design search: trigger range width over the (h, W) grid, unique-cycle designs marked."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from feeder_cell.plots.common import HIGHLIGHT_COLOUR, STABLE_COLOUR, WIDE, length_unit, new_figure
from feeder_planner.throwing import DesignSearch

__all__ = ["UNIQUE_GID", "BEST_GID", "design_figure"]

UNIQUE_GID = "unique cycle"  # gid of the markers of the designs whose limit set is one cycle
BEST_GID = "best"


def _index(values: list[float]) -> dict[float, int]:
    """Return each distinct value's column (sorted), so rows of any order land in their grid cell."""
    return {v: i for i, v in enumerate(sorted(set(values)))}


def design_figure(result: DesignSearch, unit_scale: float = 1.0, name: str = "part") -> Figure:
    """Return the trigger range width of every design of the grid, unique-cycle designs and the best marked.

    Parameters
    ----------
    result
        What ``throwing.search`` returned (one row per (h, W) of the grid).
    unit_scale
        Metres per length unit of the part file: h and the width are drawn in that unit.
    name
        The part's name, for the title.

    Returns
    -------
    Figure
        A colour grid, h across and W (deg/s) up, coloured by the width of the goal edge's sensor trigger
        range (grey: no range); a circle on every design with a unique cycle (one line, gid UNIQUE_GID)
        and a star on the best (gid BEST_GID).
    """
    scale, unit = length_unit(unit_scale)
    rows = result.designs
    cols = _index([r.offset for r in rows])
    lines = _index([r.speed for r in rows])
    width = np.full((len(lines), len(cols)), np.nan)
    for r in rows:
        if r.trigger is not None:
            width[lines[r.speed], cols[r.offset]] = r.width / scale
    figure = new_figure(WIDE)
    ax = figure.add_subplot()
    ax.set_facecolor("0.85")
    mesh = ax.pcolormesh(np.ma.masked_invalid(width), cmap="viridis", edgecolors="w", linewidth=0.5)
    figure.colorbar(mesh, ax=ax, label=f"trigger range width ({unit})")
    unique = [r for r in rows if r.unique]
    ax.plot(
        [cols[r.offset] + 0.5 for r in unique],
        [lines[r.speed] + 0.5 for r in unique],
        ls="none",
        marker="o",
        ms=9,
        mfc="none",
        mec=STABLE_COLOUR,
        mew=2,
        label=f"unique cycle ({len(unique)})",
        gid=UNIQUE_GID,
    )
    if result.best is not None:
        b = result.best
        ax.plot(
            [cols[b.offset] + 0.5],
            [lines[b.speed] + 0.5],
            ls="none",
            marker="*",
            ms=16,
            color=HIGHLIGHT_COLOUR,
            label="best",
            gid=BEST_GID,
        )
    ax.set_xticks([i + 0.5 for i in cols.values()], [f"{h / scale:.3g}" for h in cols])
    ax.set_yticks([i + 0.5 for i in lines.values()], [f"{math.degrees(w):.4g}" for w in lines])
    ax.set_xlabel(f"offset h ({unit})")
    ax.set_ylabel("release speed W (deg/s)")
    ax.set_title(f"{name}: {len(rows)} designs for goal edge {result.goal_edge} (grey: no trigger range)")
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.12), ncol=2, fontsize="small", frameon=False)
    return figure
