"""The forward limit set of a throwing-arm design: R against throw number from every start (Figs. 5, 7, 8)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from feeder_cell.plots.common import SHADE_COLOUR, TALL, edge_colour, length_unit, new_figure
from feeder_planner.errors import InputError
from feeder_planner.throwing import LimitSet

__all__ = ["START_GID", "TRIGGER_GID", "CONVERGENCE_THROWS", "CYCLES_SHOWN", "limit_set_figure"]

START_GID = "start"  # gid of each start's line in the top axes: one per start of the grid
TRIGGER_GID = "trigger range"
CONVERGENCE_THROWS = 100  # the top axes shows this many throws from every start, as the paper's Fig. 7
CYCLES_SHOWN = 4  # the bottom axes shows about this many cycles of one start at the end of its run


def _shade_trigger(ax: Axes, result: LimitSet, scale: float) -> None:
    """Shade the sensor trigger range of the goal edge, if there is one."""
    if result.trigger is None:
        return
    lo, hi = result.trigger
    ax.axhspan(
        lo / scale,
        hi / scale,
        color=SHADE_COLOUR,
        alpha=0.45,
        zorder=0,
        label=f"sensor trigger range (edge {result.goal_edge})",
        gid=TRIGGER_GID,
    )


def _edge_dots(ax: Axes, n: np.ndarray, edge: np.ndarray, radius: np.ndarray, cycle: list[int]) -> None:
    """Draw one dot per state, coloured by the edge the part rests on (legend: in the cycle or not).

    States past a row's end (NaN radius: the row stopped at recurrence or left the domain) are skipped.
    """
    valid = np.isfinite(radius)
    for e in sorted({int(v) for v in np.unique(edge[valid])}):
        mask = (edge == e) & valid
        where = "in the cycle" if e in cycle else "transient only"
        ax.scatter(n[mask], radius[mask], s=6, color=edge_colour(e), zorder=2, label=f"edge {e} ({where})")


def limit_set_figure(result: LimitSet, unit_scale: float = 1.0, name: str = "part") -> Figure:
    """Return R against throw number: every start converging (Fig. 7) and one start's cycle (Fig. 5).

    Parameters
    ----------
    result
        A ``limit_set(..., keep_trajectories=True)`` result (the states after every throw are drawn).
    unit_scale
        Metres per length unit of the part file: R is drawn in that unit, as the CLI prints it.
    name
        The part's name, for the title.

    Returns
    -------
    Figure
        Top: the first CONVERGENCE_THROWS throws from every start, one grey line per start (gid
        START_GID) with a diamond at its start and a dot per state coloured by the hull edge the part
        rests on. Bottom: the last ~CYCLES_SHOWN cycles of the longest-running start, the edges
        coloured the same way. Rows end where their states end (a NaN radius).
        Both shade the goal edge's sensor trigger range (gid TRIGGER_GID).

    Raises
    ------
    InputError
        (field ``trajectories``) when the result was computed without its trajectories.
    """
    traj = result.trajectories
    if traj is None:
        raise InputError("trajectories", "the limit set was computed without keep_trajectories=True")
    scale, unit = length_unit(unit_scale)
    cycle = result.cycle.edges if result.cycle is not None else []
    radius = traj.radius / scale
    valid = np.isfinite(radius)
    # The last state of each row: rows may stop early (recurrence found, or out of the domain).
    last = np.where(valid.any(axis=1), valid.shape[1] - 1 - np.argmax(valid[:, ::-1], axis=1), 0)
    longest = int(np.argmax(last))
    total = int(last[longest])
    figure = new_figure(TALL)
    top, bottom = figure.subplots(2, 1, height_ratios=(1.3, 1.0))

    shown = max(1, min(total, CONVERGENCE_THROWS))
    n = np.arange(shown + 1)
    for row in radius[:, : shown + 1]:
        top.plot(n, row, color="0.7", lw=0.5, zorder=1, gid=START_GID)
    grid = np.broadcast_to(n, (len(radius), shown + 1))
    _edge_dots(top, grid[:, 1:], traj.edge[:, 1 : shown + 1], radius[:, 1 : shown + 1], cycle)
    top.scatter(np.zeros(len(radius)), radius[:, 0], marker="D", s=16, color="k", zorder=3, label="starts")
    _shade_trigger(top, result, scale)
    top.set_xlim(0, shown)
    top.set_xlabel("throw number")
    top.set_ylabel(f"R ({unit})")
    if result.cycle is not None:
        c = result.cycle
        verdict = "unique" if result.unique else "not unique"
        text = f"cycle {c.edges} ({verdict}), {c.throws_per_cycle:.1f} throws"
    else:
        text = "no cycle common to all starts"
    top.set_title(f"{name}: {result.starts} starts converge to the limit set; {text}", fontsize="medium")
    top.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize="small", markerscale=1.5)

    period = result.cycle.throws_per_cycle if result.cycle is not None else 10.0
    span = min(total, max(10, math.ceil(CYCLES_SHOWN * period)))
    n = np.arange(max(0, total - span), total + 1)
    bottom.plot(n, radius[longest, n], color="0.5", lw=0.8, zorder=1)
    _edge_dots(bottom, n, traj.edge[longest, n], radius[longest, n], cycle)
    _shade_trigger(bottom, result, scale)
    bottom.set_xlim(n[0], max(n[-1], n[0] + 1))
    bottom.set_xlabel("throw number")
    bottom.set_ylabel(f"R ({unit})")
    start = f"edge {int(traj.edge[longest, 0])}, R = {radius[longest, 0]:.3g} {unit}"
    bottom.set_title(
        f"the last {len(n) - 1} of {total} throws from ({start})",
        fontsize="medium",
    )
    return figure
