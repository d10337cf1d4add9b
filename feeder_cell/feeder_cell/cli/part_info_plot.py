"""The drawing of `feeder part-info --plot`: the part as read, over the source geometry it came from."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from feeder_cell.plots.common import new_figure
from feeder_planner import polygon
from feeder_planner.cad import Outline
from feeder_planner.parts import Part

__all__ = ["part_info_figure"]


def part_info_figure(part: Part, outline: Outline | None) -> Figure:
    """Draw the part's outline and holes, its hull and centre of mass over the CAD pieces it came from.

    The pieces are wide grey lines under the outline as read (vertices marked), in the file's frame, metres.
    """
    figure = new_figure((7.0, 6.0))
    ax = figure.add_subplot(1, 1, 1)
    if outline is not None:
        lines = [
            np.vstack([piece.points, piece.points[:1]]) if piece.closed else piece.points
            for piece in outline.pieces
        ]  # one collection: a solid's 200,000 triangles draw in a second, one plot call each would not
        width = 2.5 if len(lines) < 1000 else 0.5
        ax.add_collection(
            LineCollection([line * outline.unit_scale for line in lines], colors="0.6", linewidths=width)
        )
        ax.plot([], [], color="0.6", linewidth=width, label="source entities (a solid: its triangles)")
    loops = [part.file_vertices, *(hole + part.offset for hole in part.holes)]
    for k, loop in enumerate(loops):
        closed = np.vstack([loop, loop[:1]])
        ax.fill(
            closed[:, 0], closed[:, 1], color="white" if k else "tab:blue", alpha=1.0 if k else 0.3, zorder=2
        )
        ax.plot(
            closed[:, 0],
            closed[:, 1],
            ".-",
            color="tab:blue",
            markersize=3,
            linewidth=1,
            zorder=3,
            label="outline and holes as read" if k == 0 else None,
        )
    hull = part.file_vertices[polygon.convex_hull_indices(part.file_vertices)]
    hull = np.vstack([hull, hull[:1]])
    ax.plot(hull[:, 0], hull[:, 1], "--", color="tab:orange", linewidth=1, label="convex hull", zorder=4)
    ax.plot(*part.offset, "+", color="tab:red", markersize=12, label="centre of mass", zorder=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, file frame)")
    ax.set_ylabel("y (m, file frame)")
    ax.set_title(
        f"{part.name}: area {part.area:.4g} m^2, {len(part.outer)} outline vertices, {len(part.holes)} holes"
    )
    ax.legend(loc="best", fontsize="small")
    return figure
