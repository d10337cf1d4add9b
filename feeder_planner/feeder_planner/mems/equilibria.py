"""The equilibria planner: method dispatch, input checks and the certification of 'auto' (issue item d)."""

from __future__ import annotations

import math
from dataclasses import replace

from feeder_planner.errors import InputError, SolverError
from feeder_planner.mems.asymptotic import asymptotic_equilibria
from feeder_planner.mems.fields import check_delta
from feeder_planner.mems.lifted import Edges, part_edges
from feeder_planner.mems.numeric import numeric_equilibria
from feeder_planner.mems.result import METHODS, AutoChoice, EquilibriaResult, Method, check_method
from feeder_planner.mems.tolerances import CERT_DELTAS, CERT_POSITION, CERT_THETA
from feeder_planner.parts import Part

__all__ = ["METHODS", "Method", "check_delta", "check_method", "agree", "find_equilibria"]


def agree(a: EquilibriaResult, b: EquilibriaResult, scale: float) -> bool:
    """Return whether a matches b: same count and stability, angles and positions within the window.

    Angles within CERT_THETA + delta^3 (+ twice b's theta uncertainty, the numeric side's own
    resolution) rad, positions within (CERT_POSITION + the same slack) * scale.
    """
    if len(a.equilibria) != len(b.equilibria):
        return False
    # the numeric side's own resolution (its rounding floor over the slope of x*) widens the window
    slack = a.delta**3 + 2.0 * (b.numeric.theta_uncertainty if b.numeric is not None else 0.0)
    for ea in a.equilibria:
        match = [
            eb
            for eb in b.equilibria
            if eb.stable == ea.stable
            and abs(math.remainder(ea.theta - eb.theta, 2 * math.pi)) <= CERT_THETA + slack
        ]
        if (
            not match
            or min(math.hypot(ea.x - m.x, ea.y - m.y) for m in match) > (CERT_POSITION + slack) * scale
        ):
            return False
    return True


def _certify_elsewhere(
    part: Part, delta: float, edges: Edges, asym: EquilibriaResult, refusal: SolverError
) -> EquilibriaResult:
    """Return the asymptotic result certified at the smallest CERT_DELTAS above delta where both work.

    For a delta below what the numeric curve resolves: the expansion is checked against the numeric
    method at the first larger delta where both methods succeed; a disagreement there, or no such
    delta, is a refusal.
    """
    for d_cert in CERT_DELTAS:
        if d_cert <= delta:
            continue
        try:
            check_num = numeric_equilibria(part, d_cert, edges)
            check_asym = asymptotic_equilibria(part, d_cert, edges)
        except SolverError:
            continue
        if agree(check_asym, check_num, edges.scale):
            return _chosen(asym, AutoChoice(certified_at_delta=d_cert, numeric_refused=str(refusal)))
        break
    raise SolverError(f"asymptotic result could not be certified and numeric refused: {refusal}") from None


def _auto(part: Part, delta: float, edges: Edges) -> EquilibriaResult:
    """Return the asymptotic result where the numeric method certifies it, else the numeric one."""
    try:
        asym = asymptotic_equilibria(part, delta, edges)
    except SolverError as error:
        return _chosen(numeric_equilibria(part, delta, edges), AutoChoice(asymptotic_refused=str(error)))
    try:
        num = numeric_equilibria(part, delta, edges)
    except SolverError as error:
        return _certify_elsewhere(part, delta, edges, asym, error)
    if agree(asym, num, edges.scale):
        return _chosen(asym, AutoChoice(certified_at_delta=delta))
    return _chosen(num, AutoChoice(asymptotic_disagreed=True))


def find_equilibria(part: Part, delta: float, method: Method | str = "auto") -> EquilibriaResult:
    """Return all equilibria of ``part`` in the unit radial field plus the constant field -delta (0, 1).

    That is u = |r| + delta eta (section 3.2), 0 < delta < 1; ``method`` is one of METHODS.
    """
    delta = check_delta(delta)
    chosen = check_method(method)
    edges = part_edges(part)
    if delta == 0.0:
        raise InputError(
            "delta",
            "delta = 0 leaves the orientation free (the pivot circle is a continuum of "
            "equilibria, Prop. 3); use delta > 0",
        )
    if chosen == "asymptotic":
        return asymptotic_equilibria(part, delta, edges)
    if chosen == "numeric":
        return numeric_equilibria(part, delta, edges)
    return _auto(part, delta, edges)


def _chosen(result: EquilibriaResult, why: AutoChoice) -> EquilibriaResult:
    """Return ``result`` as the answer of 'auto' (certified: 'auto' returns nothing uncertified)."""
    return replace(result, certified=True, auto=why)
