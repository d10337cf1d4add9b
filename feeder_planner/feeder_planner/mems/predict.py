"""What the planner predicts: for which field, in which step of a program, and which equilibrium is reached.

One definition each, used by the planner node, the simulator's ``~/run_program`` and the CLI:
``unpredicted_reason`` (the planner's method covers the combined field with delta > 0 only, section 3.2),
``holding_step`` (the step a program ends in and holds) and ``final_equilibrium`` (Prop. 5).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from feeder_planner.mems.fields import CombinedField, Field, ProgramStep
from feeder_planner.mems.result import EquilibriaResult, Equilibrium

__all__ = ["final_equilibrium", "holding_start", "holding_step", "unpredicted_reason"]


def unpredicted_reason(field: Field) -> str | None:
    """Return why the planner predicts no equilibria in ``field``, or None when it does.

    The equilibria planner computes the combined field u = |r - c| + delta eta with delta > 0 (section
    3.2): under the radial field alone every orientation is an equilibrium (the part turns about its
    pivot, Prop. 3), and the constant, squeeze and quadratic fields are not what its method computes.
    """
    if isinstance(field, CombinedField) and field.delta > 0:
        return None
    what = "the radial field alone (delta 0)" if isinstance(field, CombinedField) else f"a {field.kind} field"
    return (
        f"no predicted equilibria for {what}: the planner predicts them for the combined field "
        "with delta > 0 only"
    )


def holding_step(program: Sequence[ProgramStep]) -> int:
    """Return the index of the step a program ends in and holds: its first endless step, else its last."""
    for index, step in enumerate(program):
        if math.isinf(step.duration):
            return index
    return len(program) - 1


def holding_start(program: Sequence[ProgramStep]) -> float:
    """Return the time (s from the program's start) at which its holding step begins."""
    return float(sum(step.duration for step in program[: holding_step(program)]))


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
