"""The equilibria planner: method dispatch, input checks and the certification of 'auto' (issue item d)."""

from __future__ import annotations

import math

from feeder_planner.errors import InputError, SolverError
from feeder_planner.mems.asymptotic import asymptotic_equilibria
from feeder_planner.mems.lifted import part_edges
from feeder_planner.mems.numeric import numeric_equilibria
from feeder_planner.mems.result import EquilibriaResult
from feeder_planner.parts import Part

METHODS = ("auto", "asymptotic", "numeric")
# 'auto' accepts the asymptotic prediction when it matches the numeric one in count and stability,
# every angle within CERT_THETA + delta^3 rad and every position within (CERT_POSITION + delta^3) part
# radii (delta^3: the truncation order of the expansion after its EXTRA = 2 refining orders).
CERT_THETA = 1e-6
CERT_POSITION = 1e-6
CERT_DELTAS = (1e-4, 1e-3, 1e-2, 3e-2, 0.1)  # where to certify when delta is below the numeric resolution


def check_delta(delta: float, field: str = "delta") -> float:
    """0 <= delta < 1 (contract section 3); NaN and inf refused."""
    if isinstance(delta, bool) or not isinstance(delta, (int, float)) or not math.isfinite(delta):
        raise InputError(field, f"must be a finite number, got {delta!r}")
    if not 0.0 <= delta < 1.0:
        raise InputError(field, f"must satisfy 0 <= delta < 1, got {delta!r}")
    return float(delta)


def agree(a: EquilibriaResult, b: EquilibriaResult, scale: float) -> bool:
    """Same count and stability, angles within CERT_THETA + delta^3 (+ b's theta resolution), positions
    within (CERT_POSITION + the same slack) * scale.
    """
    if len(a.equilibria) != len(b.equilibria):
        return False
    # the numeric side's own resolution (its rounding floor over the slope of x*) widens the window
    slack = a.delta**3 + 2.0 * float(b.details.get("theta_uncertainty", 0.0))
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


def find_equilibria(part: Part, delta: float, method: str = "auto") -> EquilibriaResult:
    """All equilibria of ``part`` in the unit radial field plus the constant field -delta (0, 1)."""
    delta = check_delta(delta)
    if method not in METHODS:
        raise InputError("method", f"unknown method {method!r} (expected one of {', '.join(METHODS)})")
    edges = part_edges(part)
    if delta == 0.0:
        raise InputError(
            "delta",
            "delta = 0 leaves the orientation free (the pivot circle is a continuum of "
            "equilibria, Prop. 3); use delta > 0",
        )
    if method == "asymptotic":
        return asymptotic_equilibria(part, delta, edges)
    if method == "numeric":
        return numeric_equilibria(part, delta, edges)
    try:
        asym = asymptotic_equilibria(part, delta, edges)
    except SolverError as error:
        result = numeric_equilibria(part, delta, edges)
        return _relabel(result, "numeric", {"asymptotic_refused": str(error)})
    try:
        num = numeric_equilibria(part, delta, edges)
    except SolverError as error:
        # delta below what the numeric curve resolves: certify the expansion where both work.
        for d_cert in CERT_DELTAS:
            if d_cert <= delta:
                continue
            try:
                check_num = numeric_equilibria(part, d_cert, edges)
                check_asym = asymptotic_equilibria(part, d_cert, edges)
            except SolverError:
                continue
            if agree(check_asym, check_num, edges.scale):
                return _relabel(
                    asym,
                    "asymptotic",
                    {"certified": True, "certified_at_delta": d_cert, "numeric_refused": str(error)},
                )
            break
        raise SolverError(f"asymptotic result could not be certified and numeric refused: {error}") from None
    if agree(asym, num, edges.scale):
        return _relabel(asym, "asymptotic", {"certified": True, "certified_at_delta": delta})
    return _relabel(num, "numeric", {"asymptotic_disagreed": True})


def _relabel(result: EquilibriaResult, method: str, extra: dict) -> EquilibriaResult:
    return EquilibriaResult(
        result.pivot,
        result.area,
        result.delta,
        method,
        result.equilibria,
        {**result.details, **extra, "requested": "auto"},
    )
