"""One gravity direction's stability check: the assembly's bodies with the contact forces as arrows."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from feeder_cell.plots.common import (
    HIGHLIGHT_COLOUR,
    PART_COLOUR,
    SQUARE,
    STABLE_COLOUR,
    length_unit,
    new_figure,
)
from feeder_planner.assembly import Assembly, CheckResult, ContactLoad
from feeder_planner.assembly.meshes import body_surface, part_bounds

__all__ = ["FORCE_GID", "GRAVITY_GID", "FORCE_FLOOR", "drawn_forces", "stability_figure"]

FORCE_GID = "contact forces"
GRAVITY_GID = "gravity"
FORCE_FLOOR = 1e-6  # forces below this fraction of the largest are LP rounding, not drawn
ARROW_FRACTION = 0.35  # the largest force is drawn this fraction of the assembly's size long


def drawn_forces(result: CheckResult) -> list[ContactLoad]:
    """Return the contact loads drawn: those above FORCE_FLOOR of the largest (none if unstable)."""
    loads = list(result.forces or ())
    if not loads:
        return []
    largest = max(float(np.linalg.norm(f.force)) for f in loads)
    return [f for f in loads if largest > 0 and np.linalg.norm(f.force) > FORCE_FLOOR * largest]


def stability_figure(assembly: Assembly, result: CheckResult) -> Figure:
    """Return the assembly in 3-D with the contact forces of a check-stability result as arrows.

    Parameters
    ----------
    assembly
        The assembly the check was made for (its bodies' convex pieces are drawn).
    result
        What ``check_result`` returned for one gravity direction.

    Returns
    -------
    Figure
        Grounded bodies grey, free bodies blue (red: bodies the LP cannot balance), one arrow per drawn
        contact force at its point on body ``a`` (``drawn_forces``; one quiver, gid FORCE_GID) and the
        gravity direction at each free body's centre of mass (gid GRAVITY_GID). Axes in the file's unit.
    """
    scale, unit = length_unit(assembly.unit_scale)
    figure = new_figure(SQUARE)
    ax = figure.add_subplot(projection="3d")
    unbalanced = set(result.unbalanced_bodies)
    for body in assembly.bodies:
        colour = "0.7" if body.grounded else (HIGHLIGHT_COLOUR if body.name in unbalanced else PART_COLOUR)
        faces = [polygon / scale for polygon in body_surface(body)]  # pieces' faces, mesh triangles
        ax.add_collection3d(
            Poly3DCollection(faces, facecolor=colour, edgecolor="k", linewidths=0.4, alpha=0.35)
        )
    size = assembly.size / scale
    loads = drawn_forces(result)
    if loads:
        largest = max(float(np.linalg.norm(f.force)) for f in loads)
        points = np.array([f.point for f in loads]) / scale
        arrows = np.array([f.force for f in loads]) / largest * ARROW_FRACTION * size
        ax.quiver(
            *points.T,
            *arrows.T,
            color=STABLE_COLOUR,
            lw=1.5,
            label=f"contact forces ({len(loads)})",
            gid=FORCE_GID,
        )
    g = np.asarray(result.g, float)
    for index in assembly.free_bodies:
        centre = assembly.bodies[index].center / scale
        ax.quiver(
            *centre,
            *(0.4 * size * g),
            color="k",
            lw=2,
            arrow_length_ratio=0.15,
            label="gravity",
            gid=GRAVITY_GID,
        )
    parts = [p for b in assembly.bodies for p in (*b.pieces, *b.meshes)]
    lower, upper = (corner / scale for corner in part_bounds(parts))
    middle, half = (lower + upper) / 2, 0.6 * float(np.max(upper - lower))
    ax.set(xlim=(middle[0] - half, middle[0] + half), ylim=(middle[1] - half, middle[1] + half))
    ax.set_zlim(middle[2] - half, middle[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_zlabel(f"z ({unit})")
    gtext = "(" + ", ".join(f"{v:.3g}" for v in g) + ")"
    if result.stable:
        margin = "" if result.margin_rad is None else f", margin {np.degrees(result.margin_rad):.3g} deg"
        verdict = f"stable for g = {gtext}{margin}"
    else:
        verdict = f"NOT stable for g = {gtext}: {', '.join(result.unbalanced_bodies) or 'no body identified'}"
    ax.set_title(f"{assembly.name}: {verdict}", fontsize="medium")
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), loc="lower left", fontsize="small")
    return figure
