"""Which stable equilibrium a part reaches from its current orientation (Prop. 5: U* decreases along x*)."""

from __future__ import annotations

import math

from feeder_planner.mems.result import EquilibriaResult, Equilibrium

__all__ = ["final_equilibrium"]


def final_equilibrium(result: EquilibriaResult, theta: float) -> Equilibrium:
    """Return the stable equilibrium at the end of theta's arc between consecutive equilibria.

    Once the part sits on the equilibrium curve, dU*/dtheta = delta |S| x* (Prop. 5) makes theta
    run downhill; equilibria alternate stable/unstable around the circle (Prop. 6), so the arc that
    holds theta ends in exactly one stable equilibrium, which the quasi-static motion reaches.
    """
    ordered = sorted(result.equilibria, key=lambda e: e.theta)
    stable = [e for e in ordered if e.stable]
    if len(stable) == 1 or len(ordered) < 2:
        return stable[0]
    t = theta % (2 * math.pi)
    for k, e in enumerate(ordered):
        nxt = ordered[(k + 1) % len(ordered)]
        lo, hi = e.theta, nxt.theta if k + 1 < len(ordered) else nxt.theta + 2 * math.pi
        tt = t if t >= lo else t + 2 * math.pi
        if lo <= tt < hi:
            return e if e.stable else nxt
    return stable[0]
