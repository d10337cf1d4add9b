"""The drawing of `feeder squeeze-plan --plot`: diameter function, squeeze function and the plan's steps."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from feeder_cell.plots.common import new_figure
from feeder_planner.squeeze.diameter import TWO_PI, wrap
from feeder_planner.squeeze.plan import Plan
from feeder_planner.squeeze.squeeze_function import SqueezeFunction

__all__ = ["squeeze_figure"]


def squeeze_figure(name: str, squeeze: SqueezeFunction, plan: Plan) -> Figure:
    """Draw d(theta) with its exact extrema, s(theta) over [0, 2 pi), and the possible set after each step.

    The third panel shows, for each squeeze of the plan, the orientations the part may be in afterwards
    (world frame): every initial orientation's interval of the certificate, run through the plan.
    """
    figure = new_figure((8.0, 9.0))
    ax_d, ax_s, ax_p = figure.subplots(3, 1)
    thetas = np.linspace(0.0, TWO_PI, 4001)
    widths = np.array([squeeze.diameter(float(t)) for t in thetas])
    ax_d.plot(thetas, widths * 1e3, color="tab:blue", linewidth=1, label="d(theta)")
    for half in (0.0, math.pi):
        ax_d.plot(
            [m.angle + half for m in squeeze.diameter.minima],
            [m.width * 1e3 for m in squeeze.diameter.minima],
            "v",
            color="tab:green",
            label="minima (stable, exact)" if half == 0.0 else None,
        )
        ax_d.plot(
            [m.angle + half for m in squeeze.diameter.maxima],
            [m.width * 1e3 for m in squeeze.diameter.maxima],
            "^",
            color="tab:red",
            label="maxima (unstable)" if half == 0.0 else None,
        )
    ax_d.set_ylabel("jaw width (mm)")
    ax_d.set_title(f"{name}: diameter function, symmetry period {math.degrees(squeeze.period):.2f} deg")
    ax_d.legend(loc="best", fontsize="small")
    after = np.array([wrap(squeeze(float(t)), TWO_PI) for t in thetas])
    jumps = np.flatnonzero(np.abs(np.diff(after)) > 1e-9)
    after_drawn = after.copy()
    after_drawn[jumps] = np.nan  # a step's riser is not part of the function
    ax_s.plot(thetas, after_drawn, color="tab:purple", linewidth=1.5, label="s(theta)")
    ax_s.plot(thetas, thetas, ":", color="0.6", linewidth=1, label="identity")
    ax_s.set_ylabel("orientation after (rad)")
    ax_s.set_title("squeeze function")
    ax_s.legend(loc="best", fontsize="small")
    for ax in (ax_d, ax_s):
        ax.set_xlim(0.0, TWO_PI)
        ax.set_xlabel("orientation relative to the jaws (rad)")
    starts = np.linspace(0.0, TWO_PI, 721, endpoint=False)
    for k in range(len(plan.angles) + 1):
        states = starts.copy()
        for alpha in plan.angles[:k]:
            states = np.array([alpha + squeeze(float(t) - alpha) for t in states])
        ax_p.plot(
            np.full(len(states), k), np.mod(states, TWO_PI), "o", color="tab:blue", markersize=3, alpha=0.4
        )
    for k, alpha in enumerate(plan.angles, start=1):
        ax_p.annotate(
            f"{math.degrees(alpha):.1f} deg", (k, TWO_PI), fontsize="small", ha="center", va="bottom"
        )
    ax_p.set_xticks(range(len(plan.angles) + 1))
    ax_p.set_xlabel("squeezes done (gripper angle above)")
    ax_p.set_ylabel("possible orientations (rad)")
    ax_p.set_ylim(0.0, TWO_PI * 1.08)
    ax_p.set_title(
        f"plan of {len(plan.angles)}: every start ends at {plan.certificate.final:.4f} rad "
        f"mod {plan.certificate.period:.4f}"
    )
    return figure
