"""Goldberg's shortest squeeze plan, its completeness certificate, and an exhaustive check of its length.

A squeeze at gripper angle alpha takes a part at world orientation theta to alpha + s(theta - alpha)
(s the squeeze function). A plan alpha_1..alpha_k orients the part if every initial orientation in
[0, 2 pi), but a set of measure zero (the unstable equilibria), ends at one orientation modulo the
squeeze function's symmetry period T.

Goldberg's backchaining (1993, section 4), over the steps of one period T: an s-interval Theta is a run
of consecutive steps; its length |Theta| = m_end - m_start, its image width |s(Theta)| = f_last - f_first.
A set of orientations inside an arc narrower than |Theta| can be placed inside Theta by one squeeze, and
ends inside an arc of width |s(Theta)|. So, with Theta_1 the widest single step (image width 0):

    Theta_{i+1} = the longest s-interval with |s(Theta_{i+1})| < |Theta_i|,

until the first squeeze's image fits: from complete uncertainty one squeeze leaves every fixed point of
a period, an arc of width T - g (g the widest gap between consecutive fixed points); if T - g < |Theta_i|
the plan has i + 1 squeezes. The O(n^2) runs are sorted by image width once, with the running maximum of
their lengths, so each step of the chain is a binary search: O(n^2 log n) in all, Goldberg's bound.

The plan is then executed forward on the exact finite sets of fixed points, and its certificate lists the
initial intervals covering [0, 2 pi), each with its final orientation; ``check_certificate`` re-derives it.
``shortest_plan_length`` is an independent lower bound: a breadth-first search over every distinct
squeeze (the angles between the breakpoints p - m_j, where the outcome changes), exhaustive, so a plan
length it reports is certified to be the shortest.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import InputError, SolverError
from feeder_planner.limits import check_count
from feeder_planner.squeeze.diameter import TWO_PI, wrap
from feeder_planner.squeeze.squeeze_function import SqueezeFunction, check_angle
from feeder_planner.squeeze.tolerances import (
    FINAL_TOLERANCE,
    MAX_PLAN_SQUEEZES,
    MAX_SEARCH_STATES,
    MAX_STEPS_PER_PERIOD,
)

__all__ = [
    "Interval",
    "Plan",
    "PlanCertificate",
    "apply_plan",
    "check_certificate",
    "check_plan_angles",
    "plan_squeezes",
    "shortest_plan_length",
]


@dataclass(frozen=True)
class Interval:
    """A run of consecutive steps of one period: its start boundary index, step count, length, width."""

    first: int
    steps: int
    length: float
    image_width: float


@dataclass(frozen=True)
class PlanCertificate:
    """Completeness of a plan: initial intervals covering [0, 2 pi) and the final orientation of each.

    ``starts[i]`` to ``starts[i + 1]`` (the last to ``starts[0] + 2 pi``) ends at ``finals[i]`` (rad, world
    frame); every final is ``final`` modulo ``period``. ``margin`` is the smallest distance (rad) of any
    intermediate orientation from an unstable one, the plan's tolerance to gripper angle errors.
    """

    starts: tuple[float, ...]
    finals: tuple[float, ...]
    final: float
    period: float
    margin: float
    # The largest Coulomb friction (jaws and part) under which no squeeze after the first jams: the tangent
    # of the smallest angle between a contact chord and the jaws' normal at any intermediate orientation
    # (``friction.jams``). Infinite for a plan of one squeeze.
    friction_tolerance: float = math.inf


@dataclass(frozen=True)
class Plan:
    """A squeeze plan: gripper angles (rad, world frame), the backchained intervals and the certificate."""

    angles: tuple[float, ...]
    intervals: tuple[Interval, ...]
    certificate: PlanCertificate

    def to_json(self) -> dict[str, object]:
        """Return the plan as a JSON object (SI units)."""
        c = self.certificate
        return {
            "angles": list(self.angles),
            "squeezes": len(self.angles),
            "final_orientation": c.final,
            "symmetry_period": c.period,
            "margin": c.margin,
            "friction_tolerance": c.friction_tolerance,
            "intervals": [{"start": s, "final": f} for s, f in zip(c.starts, c.finals, strict=True)],
        }


def check_plan_angles(angles: object, field: str = "plan") -> tuple[float, ...]:
    """Return a plan as given: a non-empty list of finite angles (rad); refused naming the field otherwise."""
    if not isinstance(angles, (list, tuple)):
        raise InputError(field, f"expected a list of squeeze angles, got {type(angles).__name__}")
    if not angles:
        raise InputError(field, "a plan needs at least one squeeze, got none")
    check_count(len(angles), MAX_PLAN_SQUEEZES, field, "squeezes")
    return tuple(check_angle(a, f"{field}[{i}]") for i, a in enumerate(angles))


def apply_plan(squeeze: SqueezeFunction, angles: Sequence[float], theta: float) -> float:
    """Return the world orientation after squeezing at each angle in turn from ``theta`` (ideal model)."""
    for alpha in angles:
        theta = alpha + squeeze(theta - alpha)
    return theta


def _runs(bounds: np.ndarray, fixed: np.ndarray, period: float) -> tuple[np.ndarray, ...]:
    """Every run of 1..n-1 consecutive steps of one period (lifted across the period's end), as arrays.

    Returns (first, steps, length, image_width), one entry a run: the O(n^2) runs as numpy arrays, not
    objects, so that a part with a thousand stable orientations a period plans in seconds.
    """
    n = len(fixed)
    grid_first, grid_steps = np.meshgrid(np.arange(n), np.arange(1, n), indexing="ij")
    first, steps = grid_first.ravel(), grid_steps.ravel()
    end = first + steps
    last = end - 1
    length = bounds[end % n] + period * (end // n) - bounds[first]
    image = fixed[last % n] + period * (last // n) - fixed[first]
    return first, steps, length, image


def _running_argmax(values: np.ndarray) -> np.ndarray:
    """Index of the largest of values[0..k] for each k (the first of equals)."""
    running = np.maximum.accumulate(values)
    # The first position at which each running maximum is reached.
    change = np.flatnonzero(np.r_[True, running[1:] != running[:-1]])
    return change[np.searchsorted(change, np.arange(len(values)), side="right") - 1]


def _covering_arc(points: Sequence[float], period: float) -> tuple[float, float]:
    """Return the shortest arc (start, width) modulo ``period`` holding every point."""
    values = sorted(wrap(p, period) for p in points)
    if len(values) == 1:
        return values[0], 0.0
    gaps = [values[i + 1] - values[i] for i in range(len(values) - 1)]
    gaps.append(values[0] + period - values[-1])
    widest = int(np.argmax(gaps))
    start = values[(widest + 1) % len(values)]
    return start, period - gaps[widest]


def _distinct(points: Sequence[float], period: float) -> list[float]:
    """Return the points modulo ``period`` with those within FINAL_TOLERANCE merged."""
    values = sorted(wrap(p, period) for p in points)
    merged: list[float] = []
    for v in values:
        if not merged or v - merged[-1] > FINAL_TOLERANCE:
            merged.append(v)
    if len(merged) > 1 and merged[0] + period - merged[-1] <= FINAL_TOLERANCE:
        merged.pop()
    return merged


def plan_squeezes(
    squeeze: SqueezeFunction, first_angle: float = 0.0, max_steps: int = MAX_STEPS_PER_PERIOD
) -> Plan:
    """Goldberg's shortest plan for the part of ``squeeze``, starting with a squeeze at ``first_angle``.

    Raises SolverError if the backchaining stalls or the forward execution does not end at one
    orientation modulo the symmetry period (neither happens for a polygon; nothing uncertified returns).
    """
    first_angle = check_angle(first_angle, "first_angle")
    if squeeze.steps_per_period() > max_steps:
        raise InputError(
            "vertices",
            f"the squeeze function has {squeeze.steps_per_period()} stable orientations a period; "
            f"the planner's limit is {max_steps}",
        )
    period = squeeze.period
    bounds, fixed = squeeze.period_steps()
    n = len(fixed)
    gaps = [float(fixed[(j + 1) % n] + (period if j + 1 == n else 0.0) - fixed[j]) for j in range(n)]
    first_width = period - max(gaps)
    chain: list[Interval] = []
    if n > 1:
        first, steps, length, image = _runs(bounds, fixed, period)
        order = np.argsort(image, kind="stable")
        widths = image[order]
        # best[k]: the index (into the runs) of the longest run whose image is at most widths[k] wide.
        best = order[_running_argmax(length[order])]

        def run_at(i: int) -> Interval:
            return Interval(int(first[i]), int(steps[i]), float(length[i]), float(image[i]))

        singles = np.flatnonzero(steps == 1)
        current = run_at(int(singles[np.argmax(length[singles])]))
        chain.append(current)
        while not first_width < current.length - FINAL_TOLERANCE:
            # Runs whose image is strictly narrower than the current run (with the tolerance).
            k = int(np.searchsorted(widths, current.length - FINAL_TOLERANCE, side="left")) - 1
            if k < 0 or length[best[k]] <= current.length + FINAL_TOLERANCE:
                raise SolverError(f"the backchaining stalled at an interval of {current.length:.6f} rad")
            current = run_at(int(best[k]))
            chain.append(current)
    angles = [first_angle]
    # After the first squeeze every fixed point of the squeeze function is possible (each basin has
    # positive measure); the set is exact and finite from here on.
    state = _distinct([first_angle + f for f in fixed], period)
    for interval in reversed(chain):
        start, width = _covering_arc(state, period)
        middle = float(bounds[interval.first]) + 0.5 * interval.length
        alpha = wrap(start + 0.5 * width - middle, TWO_PI)
        angles.append(alpha)
        state = _distinct([alpha + squeeze(p - alpha) for p in state], period)
    if len(state) != 1:
        raise SolverError(f"the plan of {len(angles)} squeezes leaves {len(state)} orientations")
    certificate = _certificate(squeeze, angles)
    return Plan(angles=tuple(angles), intervals=tuple(reversed(chain)), certificate=certificate)


def _certificate(squeeze: SqueezeFunction, angles: Sequence[float]) -> PlanCertificate:
    """Return the initial intervals over [0, 2 pi) (the first squeeze's steps) and where each one ends."""
    period = squeeze.period
    first = angles[0]
    starts: list[float] = []
    finals: list[float] = []
    margin = math.inf
    chord = math.pi / 2  # the smallest |theta - beta| met by a squeeze after the first
    for half in (0.0, math.pi):
        for m, f in zip(squeeze.maxima, squeeze.minima, strict=True):
            starts.append(first + m + half)
            theta = first + f + half
            for alpha in angles[1:]:
                margin = min(margin, squeeze.boundary_distance(theta - alpha))
                chord = min(chord, _chord_angle(squeeze, theta - alpha))
                theta = alpha + squeeze(theta - alpha)
            finals.append(wrap(theta, TWO_PI))
    final = wrap(finals[0], period)
    for value in finals:
        if abs(math.remainder(value - final, period)) > FINAL_TOLERANCE:
            raise SolverError(f"the plan ends at {value:.9f} and {final:.9f} rad, apart modulo {period:.6f}")
    tolerance = math.tan(chord) if len(angles) > 1 else math.inf
    return PlanCertificate(tuple(starts), tuple(finals), final, period, margin, tolerance)


def _chord_angle(squeeze: SqueezeFunction, theta: float) -> float:
    """Return |theta - beta|: the contact chord's angle from the jaws' normal at ``theta`` (rad)."""
    diameter = squeeze.diameter
    reduced = diameter.pieces[0].start + wrap(theta - diameter.pieces[0].start, math.pi)
    return abs(reduced - diameter.piece_at(theta).phase)


def check_certificate(squeeze: SqueezeFunction, plan: Plan) -> None:
    """Re-derive the certificate: the intervals tile [0, 2 pi) and each ends at the final orientation.

    Each interval's middle, and points a hundredth of its length inside each end, are run through the
    plan with the squeeze function; raises SolverError naming the first disagreement.
    """
    c = plan.certificate
    starts = [*c.starts, c.starts[0] + TWO_PI]
    if not all(starts[i] < starts[i + 1] for i in range(len(c.starts))):
        raise SolverError("the certificate's intervals are not in increasing order")
    if abs(starts[-1] - starts[0] - TWO_PI) > FINAL_TOLERANCE:
        raise SolverError("the certificate's intervals do not cover [0, 2 pi)")
    for i in range(len(c.starts)):
        a, b = starts[i], starts[i + 1]
        for t in (0.01, 0.5, 0.99):
            end = apply_plan(squeeze, plan.angles, a + t * (b - a))
            if abs(math.remainder(end - c.finals[i], TWO_PI)) > FINAL_TOLERANCE:
                raise SolverError(
                    f"interval {i} ends at {end:.9f} rad, the certificate says {c.finals[i]:.9f}"
                )
            if abs(math.remainder(end - c.final, c.period)) > FINAL_TOLERANCE:
                raise SolverError(f"interval {i} ends at {end:.9f} rad, not the final orientation")


def _canonical(state: Sequence[float], period: float) -> tuple[int, ...]:
    """Return a set of orientations up to a common rotation (the next angle is free): its gaps."""
    values = sorted(state)
    gaps = [values[i + 1] - values[i] for i in range(len(values) - 1)] + [values[0] + period - values[-1]]
    keys = [round(g / FINAL_TOLERANCE / 10) for g in gaps]
    return min(tuple(keys[i:] + keys[:i]) for i in range(len(keys)))


def shortest_plan_length(squeeze: SqueezeFunction, limit: int = 12) -> int:
    """Return the length of the shortest plan, by exhaustive breadth-first search (Goldberg's result checked).

    After the first squeeze the state is the finite set of fixed points; a squeeze's outcome depends on
    alpha only through which step each orientation falls in, which changes only where p - alpha is a step
    boundary, so one angle between each pair of consecutive breakpoints tries every distinct squeeze.
    Raises SolverError past ``limit`` squeezes or MAX_SEARCH_STATES states (no uncertified bound).
    """
    period = squeeze.period
    bounds, fixed = squeeze.period_steps()
    start = _distinct(list(fixed), period)
    if len(start) == 1:
        return 1
    seen = {_canonical(start, period)}
    frontier = [start]
    for depth in range(2, limit + 1):
        following: list[list[float]] = []
        for state in frontier:
            cuts = sorted(wrap(p - m, period) for p in state for m in bounds[:-1])
            cuts.append(cuts[0] + period)
            for k in range(len(cuts) - 1):
                if cuts[k + 1] - cuts[k] <= FINAL_TOLERANCE:
                    continue
                alpha = 0.5 * (cuts[k] + cuts[k + 1])
                image = _distinct([alpha + squeeze(p - alpha) for p in state], period)
                if len(image) == 1:
                    return depth
                key = _canonical(image, period)
                if key not in seen:
                    seen.add(key)
                    following.append(image)
                    if len(seen) > MAX_SEARCH_STATES:
                        raise SolverError(f"the search passed {MAX_SEARCH_STATES} states at depth {depth}")
        if not following:
            raise SolverError(f"no plan orients this part (search exhausted at {depth} squeezes)")
        frontier = following
    raise SolverError(f"no plan of at most {limit} squeezes was found")
