"""When parts on the array have settled, and which of the planner's predicted equilibria they reached.

The two facts the array's ``~/run_program`` action reports, free of ROS:

* **Settled.** A part has settled when its pose has stayed within ``tolerance`` of one pose (position in
  metres, orientation in radians, as RunProgram.action defines it) for ``dwell`` seconds of the node clock,
  while the program holds its final field (``holding_step``): a part at rest in an earlier step of a
  program is not done, the program is still going to move it.
* **Reached.** The planner's stable equilibria for the held field are the local minima of the lifted
  potential U (eq. 12), the points where the equilibrium curve (eqs. 13-14) crosses the y axis from left
  to right (Prop. 6). They are computed by ``feeder_planner.mems.find_equilibria`` (the planner's one
  definition, also behind ``feeder equilibria`` and the planner node's ``~/equilibria``) and translated to
  the field's centre as the planner node does; a part's final pose is matched to the nearest stable one
  by wrapped orientation. The planner predicts equilibria for the combined field
  ``u = |r - c| + delta eta`` with ``delta > 0`` only (section 3.2): under the radial field alone every
  orientation is an equilibrium (the part turns about its pivot point, Prop. 3), and the constant,
  squeeze and quadratic fields are not what its method computes; for those the prediction is absent and
  says why.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from feeder_planner.errors import FeederError, InputError
from feeder_planner.limits import MAX_GOAL_TIMEOUT
from feeder_planner.mems import (
    CombinedField,
    Field,
    find_equilibria,
    holding_start,
    holding_step,
    unpredicted_reason,
)
from feeder_planner.parts import Part

__all__ = [
    "DEFAULT_TOLERANCE",
    "DEFAULT_DWELL",
    "EQUILIBRIUM_ANGLE_TOLERANCE",
    "EQUILIBRIUM_DISTANCE_TOLERANCE",
    "SettlingCriterion",
    "settling_criterion",
    "check_timeout",
    "SettlingDetector",
    "holding_step",
    "holding_start",
    "PredictedEquilibrium",
    "Prediction",
    "predict",
    "Predictions",
    "Match",
    "match",
    "equilibrium_summary",
    "wrapped_distance",
]

# A goal's tolerance 0 means this: 1 um (a hundredth of the default 100 um pitch) and 1e-6 rad. Over the
# default dwell that is a speed of 2 um/s and 2e-6 rad/s; quasi-static motion decays exponentially near a
# stable equilibrium, so a part that moves this little over half a second is within a few um and a few
# 1e-6 rad of its rest pose (the example parts of docs/mems.md: 1e-7 rad and 1e-8 m off the planner's
# equilibrium in the ideal model when detected).
DEFAULT_TOLERANCE: Final = 1e-6
# A goal's dwell 0 means this (s of node clock): ten ticks of the default 20 Hz publish rate, long enough
# that a pause between two steps of a program's transient is not taken for rest.
DEFAULT_DWELL: Final = 0.5
# A settled part is "at" a predicted equilibrium within these: 0.01 rad, twelve times the 8e-4 rad by
# which the 'array' model (100 um cells) puts the bracket off the ideal equilibrium, and a tenth of the
# default pitch in position. Stable equilibria of the example parts are at least pi/2 apart.
EQUILIBRIUM_ANGLE_TOLERANCE: Final = 0.01
EQUILIBRIUM_DISTANCE_TOLERANCE: Final = 1e-5

TWO_PI: Final = 2 * math.pi
CLOCK_RESOLUTION: Final = 1e-9  # s


@dataclass(frozen=True)
class SettlingCriterion:
    """A part has settled when its pose stays within ``tolerance`` (m and rad) for ``dwell`` seconds."""

    tolerance: float
    dwell: float


def _finite_at_least_zero(value: float, field: str) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value < 0
    ):
        raise InputError(field, f"must be a finite number >= 0 (0: the default), got {value!r}")
    return float(value)


def settling_criterion(tolerance: float, dwell: float) -> SettlingCriterion:
    """Return the criterion of a goal's ``tolerance`` and ``dwell``; 0 picks the default of each.

    Raises
    ------
    InputError
        Naming ``tolerance`` or ``dwell`` when it is negative, NaN or infinite.
    """
    tolerance = _finite_at_least_zero(tolerance, "tolerance")
    dwell = _finite_at_least_zero(dwell, "dwell")
    return SettlingCriterion(tolerance or DEFAULT_TOLERANCE, dwell or DEFAULT_DWELL)


def check_timeout(timeout: float, field: str = "timeout") -> float:
    """Return ``timeout`` (s) if it is in (0, MAX_GOAL_TIMEOUT], else raise InputError naming ``field``."""
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, (int, float))
        or not math.isfinite(timeout)
        or timeout <= 0
    ):
        raise InputError(field, f"must be a finite number > 0 (s of the node clock), got {timeout!r}")
    if timeout > MAX_GOAL_TIMEOUT:
        raise InputError(field, f"must be at most {MAX_GOAL_TIMEOUT:.6g} s (a year), got {timeout!r}")
    return float(timeout)


def wrapped_distance(a: float, b: float) -> float:
    """Return |a - b| wrapped to [0, pi] (rad)."""
    return abs(math.remainder(a - b, TWO_PI))


class SettlingDetector:
    """Per part, whether its pose has stayed within the tolerance of one pose for the dwell time.

    Each part has an anchor, a pose and the time it was taken; a pose farther than the tolerance from
    the anchor (in position, or in wrapped orientation) becomes the new anchor. A part has settled once
    its anchor is at least ``dwell`` old. Samples taken before the program holds its final field are not
    judged, so the dwell counts from the first sample in that field.
    """

    def __init__(self, count: int, criterion: SettlingCriterion) -> None:
        self.criterion = criterion
        self.anchor = np.full((count, 3), np.nan)
        self.anchor_time = np.zeros(count)
        self.settled: tuple[bool, ...] = (False,) * count

    def update(self, now: float, poses: np.ndarray, judging: bool = True) -> tuple[bool, ...]:
        """Take the parts' poses (n, 3: x, y, theta) at time ``now`` (s); return the settled flags.

        ``judging`` False (the program is before its holding step): none settled, and the dwell of each
        part counts from the first judged sample on.
        """
        poses = np.asarray(poses, float).reshape(-1, 3)
        tolerance = self.criterion.tolerance
        flags = []
        if not judging:
            self.anchor[:] = np.nan
            self.settled = (False,) * len(poses)
            return self.settled
        for i, pose in enumerate(poses):
            anchor = self.anchor[i]
            moved = (
                bool(np.isnan(anchor).any())
                or math.hypot(pose[0] - anchor[0], pose[1] - anchor[1]) >= tolerance
                or wrapped_distance(float(pose[2]), float(anchor[2])) >= tolerance
            )
            if moved:
                self.anchor[i] = pose
                self.anchor_time[i] = now
            # to the nanosecond, the node clock's resolution: 1.15 - 0.65 is 0.5 less 1e-16
            flags.append(bool(now - self.anchor_time[i] >= self.criterion.dwell - CLOCK_RESOLUTION))
        self.settled = tuple(flags)
        return self.settled

    @property
    def all_settled(self) -> bool:
        """Whether every part has settled (True for no parts at all)."""
        return all(self.settled)


@dataclass(frozen=True)
class PredictedEquilibrium:
    """A stable equilibrium of the planner, in the plane frame (the field's centre added)."""

    index: int  # in the planner's list of equilibria (stable and unstable, as ~/equilibria gives them)
    x: float
    y: float
    theta: float  # rad, [0, 2 pi)


@dataclass(frozen=True)
class Prediction:
    """The stable equilibria predicted for one part in one field, or why there are none."""

    stable: tuple[PredictedEquilibrium, ...]
    reason: str = ""  # why nothing is predicted; empty when ``stable`` holds the prediction

    @property
    def predicted(self) -> bool:
        """Whether the planner predicts equilibria here."""
        return bool(self.stable)


def predict(part: Part, field: Field, method: str = "auto") -> Prediction:
    """Return the planner's stable equilibria of ``part`` in ``field``, or an empty prediction saying why.

    Only the combined field with delta > 0 has planned equilibria (section 3.2); a refusal of the
    planner (``find_equilibria`` cannot certify them, e.g. a symmetric part at a tiny delta) is an
    absent prediction too, with the planner's reason.
    """
    reason = unpredicted_reason(field)
    if reason is not None or not isinstance(field, CombinedField):
        return Prediction((), reason or "")
    try:
        result = find_equilibria(part, field.delta, method)
    except FeederError as error:
        return Prediction((), f"no predicted equilibria: the planner refused ({error})")
    cx, cy = field.center
    stable = tuple(
        PredictedEquilibrium(index, e.x + cx, e.y + cy, e.theta % TWO_PI)
        for index, e in enumerate(result.equilibria)
        if e.stable
    )
    if not stable:  # pragma: no cover - U has a minimum for delta < 1, so a certified answer has one
        return Prediction((), "no predicted equilibria: the planner found no stable one")
    return Prediction(stable)


class Predictions:
    """Each part's prediction in a field, computed once per (part index, field).

    Keyed by the part's index in the scene's bodies, which a removal shifts: ``clear`` when the parts change.
    """

    def __init__(self) -> None:
        self._known: dict[tuple[int, Field], Prediction] = {}

    def of(self, parts: Sequence[Part], field: Field) -> list[Prediction]:
        """Return the prediction of every part in ``field``, in the order of ``parts``."""
        for index, part in enumerate(parts):
            if (index, field) not in self._known:
                self._known[(index, field)] = predict(part, field)
        return [self._known[(index, field)] for index in range(len(parts))]

    def clear(self) -> None:
        """Forget every prediction."""
        self._known.clear()


@dataclass(frozen=True)
class Match:
    """A pose against a prediction: the nearest stable equilibrium and whether the part is at it."""

    index: int  # the equilibrium's index in the planner's list when the part is at it, else -1
    theta: float  # the nearest stable equilibrium's orientation (rad); NaN when none is predicted
    distance: float  # wrapped |theta - that theta| (rad); NaN when none is predicted
    position_distance: float  # m from that equilibrium's position; NaN when none is predicted
    at: bool


NO_MATCH: Final = Match(-1, math.nan, math.nan, math.nan, False)


def match(
    prediction: Prediction,
    pose: Sequence[float] | np.ndarray,
    angle_tolerance: float = EQUILIBRIUM_ANGLE_TOLERANCE,
    distance_tolerance: float = EQUILIBRIUM_DISTANCE_TOLERANCE,
) -> Match:
    """Return the nearest predicted stable equilibrium (by wrapped orientation) to ``pose`` (x, y, theta).

    The part is at it when both the orientation and the position are within the tolerances; otherwise
    the index is -1 and the nearest equilibrium's orientation and distance are still given.
    """
    if not prediction.predicted:
        return NO_MATCH
    x, y, theta = (float(v) for v in pose)
    nearest = min(
        prediction.stable,
        key=lambda e: (wrapped_distance(theta, e.theta), math.hypot(x - e.x, y - e.y)),
    )
    distance = wrapped_distance(theta, nearest.theta)
    off = math.hypot(x - nearest.x, y - nearest.y)
    at = distance <= angle_tolerance and off <= distance_tolerance
    return Match(nearest.index if at else -1, nearest.theta, distance, off, at)


def equilibrium_summary(name: str, prediction: Prediction, found: Match) -> str:
    """Say where a part ended against its prediction, for a run's result message."""
    if not prediction.predicted:
        return f"{name}: {prediction.reason}"
    if found.at:
        return (
            f"{name}: at predicted equilibrium {found.index} (theta {found.theta:.6g} rad, "
            f"{found.distance:.2g} rad and {found.position_distance:.2g} m off)"
        )
    return (
        f"{name}: at no predicted equilibrium (the nearest, theta {found.theta:.6g} rad, is "
        f"{found.distance:.2g} rad and {found.position_distance:.2g} m off)"
    )
