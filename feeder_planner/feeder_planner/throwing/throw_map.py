"""The throw map f: (i0, R0) -> (i1, R1) of section III-C (impulsive throw, flight, sticking catch, rest)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, get_args

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.throwing.flight import earliest_impact, flight_state, rest_pose
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import grasp_radius
from feeder_planner.throwing.impact import sticking_impact
from feeder_planner.throwing.rolling import outside_cone, settle
from feeder_planner.throwing.tolerances import GRASP_SLACK, TURN_NUDGE

__all__ = [
    "ThrowKind",
    "THROW_KINDS",
    "ThrowParams",
    "check_grasp_parameters",
    "radius_in_domain",
    "BelowGraspError",
    "whole_turns",
    "is_jog",
    "throw_kind",
    "ThrowBatch",
    "lowest_radius",
    "check_start",
    "throw_batch",
    "throw_rows",
    "ASSUMPTIONS",
    "ThrowResult",
    "throw",
]

ThrowKind = Literal["jog", "flip"]
THROW_KINDS: tuple[ThrowKind, ...] = get_args(ThrowKind)


def _require_finite(name: str, value: Any) -> None:
    """Refuse a value that is not a finite number, naming the field."""
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(name, f"must be a finite number, got {value!r}")


def _require_friction(mu: float) -> None:
    """Refuse mu <= 0: eqs. (2), (4) divide by mu, and Prop. III.3 needs mu > 0."""
    if mu <= 0:
        raise InputError("mu", f"must be > 0, got {mu!r}")


def check_grasp_parameters(offset: float, mu: float) -> None:
    """Refuse the inputs of the grasp radii, eqs. (1)-(4): a non-finite offset h, or mu not finite and > 0."""
    _require_finite("offset", offset)
    _require_finite("mu", mu)
    _require_friction(mu)


@dataclass(frozen=True)
class ThrowParams:
    """Design parameters: offset h (m), release speed W (rad/s), gravity g (m/s^2, < 0), friction mu.

    ``arm_length`` (m, > 0; default unbounded, as in the paper) is how far the arm reaches right of the
    pivot: a contact beyond it is flagged ``off_arm`` (issue 14 item 2).
    """

    offset: float
    speed: float
    gravity: float
    mu: float
    arm_length: float = math.inf

    def __post_init__(self) -> None:
        for name, value in (
            ("offset", self.offset),
            ("release_speed", self.speed),
            ("gravity", self.gravity),
            ("mu", self.mu),
        ):
            _require_finite(name, value)
        if self.gravity >= 0:
            raise InputError("gravity", f"must be < 0 (gravity pulls along -y), got {self.gravity!r}")
        if self.speed <= 0:
            raise InputError("release_speed", f"must be > 0 (counter-clockwise throw), got {self.speed!r}")
        _require_friction(self.mu)
        if not isinstance(self.arm_length, (int, float)) or math.isnan(self.arm_length):
            raise InputError("arm_length", f"must be a number > 0 (or inf), got {self.arm_length!r}")
        if self.arm_length <= 0:
            raise InputError("arm_length", f"must be > 0, got {self.arm_length!r}")


def radius_in_domain(radius: Any, bound: Any) -> Any:
    """Return whether R >= ``bound``, up to the relative GRASP_SLACK.

    ``bound`` is R_grasp or the lowest throwable R.

    The one definition of "at or above the bound" for the throw map's domain: R exactly at R_grasp is
    accepted (Prop. III.3 includes it). Works on floats and on arrays (elementwise).
    """
    return radius >= bound - GRASP_SLACK * np.abs(bound)


class BelowGraspError(InputError):
    """A start below R_grasp: the impulsive throw is not in a dynamic grasp (eqs. 1-4).

    Carries the values in metres so that a caller can restate them in its own length unit.
    """

    def __init__(self, edge: int, radius: float, r_grasp: float, scale: float = 1.0, unit: str = "m") -> None:
        self.edge, self.radius, self.r_grasp = edge, radius, r_grasp
        super().__init__(
            "radius",
            f"R = {radius / scale:.6g} {unit} is below R_grasp = {r_grasp / scale:.6g} {unit} "
            f"of edge {edge}: "
            "the impulsive throw is not in a dynamic grasp (eqs. 1-4)",
        )

    def in_unit(self, scale: float, unit: str) -> BelowGraspError:
        """Return the same error with R and R_grasp stated in ``unit`` (``scale`` metres per unit)."""
        return BelowGraspError(self.edge, self.radius, self.r_grasp, scale, unit)


def whole_turns(rotation: Any) -> np.ndarray:
    """Return the whole turns in a net rotation (toward zero), nudged TURN_NUDGE of a turn outward.

    The one turn count of both fidelities: a rotation meant to be exactly k turns that rounding left a
    hair short still counts k.
    """
    rotation = np.asarray(rotation, dtype=float)
    return np.trunc(rotation / (2 * math.pi) + np.sign(rotation) * TURN_NUDGE).astype(int)


def is_jog(start_edge: Any, end_edge: Any, rotation: Any) -> Any:
    """Return whether a throw is a jog: same edge, net rotation under pi; anything else is a flip (III-C)."""
    return (end_edge == start_edge) & (np.abs(rotation) < math.pi)


def throw_kind(start_edge: int, end_edge: int, rotation: float) -> ThrowKind:
    """Return "jog" or "flip" for one throw (section III-C)."""
    return "jog" if bool(is_jog(start_edge, end_edge, rotation)) else "flip"


ASSUMPTIONS: tuple[str, ...] = ("lift_off", "slip", "off_arm", "toe_stub")


@dataclass(frozen=True)
class ThrowBatch:
    """Results of a batch of throws, with the model's assumptions checked per throw (issue 14 item 2).

    ``lift_off``: the normal force at some rolling pivot would turn negative (the part would hop);
    ``slip``: the catch or a later strike needs an impulse outside the friction cone of mu;
    ``off_arm``: a contact point (catch, pivot, rest) lies left of the pivot or beyond the arm's end;
    ``toe_stub``: at rest the left contact vertex lies left of the pivot, so the next throw is refused.
    None (a batch built without them) reads as all false.
    """

    edge: np.ndarray  # i1
    radius: np.ndarray  # R1 (m)
    rotation: np.ndarray  # net rotation of the part over flight and settling (rad, counter-clockwise +)
    flight_time: np.ndarray
    impacts: np.ndarray
    lift_off: np.ndarray | None = None
    slip: np.ndarray | None = None
    off_arm: np.ndarray | None = None
    toe_stub: np.ndarray | None = None

    def flag(self, name: str) -> np.ndarray:
        """Return the per-throw flag ``name`` (one of ASSUMPTIONS), all false when the batch has none."""
        value = getattr(self, name)
        return np.zeros(len(self.edge), dtype=bool) if value is None else np.asarray(value, dtype=bool)

    @property
    def turns(self) -> np.ndarray:
        """Whole turns contained in the net rotation (toward zero)."""
        return whole_turns(self.rotation)

    def is_jog(self, start_edge: np.ndarray) -> np.ndarray:
        """Return per throw whether it was a jog from ``start_edge``; anything else is a flip (III-C)."""
        return np.asarray(is_jog(start_edge, self.edge, self.rotation))


def lowest_radius(part: ArmPart, edge: int, params: ThrowParams) -> float:
    """Return the smallest throwable R: R_grasp, and the left contact vertex right of the pivot.

    The second bound is the paper's assumption that the part lies right of the pivot (no stubbed toe).
    """
    return max(grasp_radius(part, edge, params.offset, params.mu), -float(part.u_left[edge]))


def check_start(part: ArmPart, edge: int, radius: float, params: ThrowParams) -> None:
    """Refuse a start outside the map's domain: unstable edge, R below R_grasp, or a stubbed toe."""
    if not (0 <= edge < part.n):
        raise InputError("edge", f"no hull edge {edge} (the hull has edges 0..{part.n - 1})")
    if not math.isfinite(radius):
        raise InputError("radius", f"must be finite, got {radius!r}")
    r_grasp = grasp_radius(part, edge, params.offset, params.mu)  # raises for an unstable edge
    if not radius_in_domain(radius, r_grasp):
        raise BelowGraspError(edge, radius, r_grasp)
    if radius + float(part.u_left[edge]) <= 0:
        raise InputError(
            "radius",
            f"R = {radius:.6g} m puts the left contact vertex left of the pivot: it would "
            "move into the arm at release (the paper assumes the part right of the pivot)",
        )


def throw_batch(part: ArmPart, edge: np.ndarray, radius: np.ndarray, params: ThrowParams) -> ThrowBatch:
    """Apply f to every (edge[b], radius[b]) at once (callers have checked the domain).

    Flight to the earliest impact (eqs. 5, 6), the sticking impact of the striking vertex (eqs. 7-9),
    then rolling to rest (section III-B); the assumptions are checked on the way (``ThrowBatch``).
    """
    return throw_rows(
        part, edge, radius, params.offset, params.speed, params.gravity, params.mu, params.arm_length
    )


def throw_rows(
    part: ArmPart,
    edge: np.ndarray,
    radius: np.ndarray,
    offset: Any,
    speed: Any,
    gravity: float,
    mu: Any,
    arm_length: Any = math.inf,
) -> ThrowBatch:
    """Apply f to every row, each with its own offset h and release speed W (scalars broadcast).

    The batch of a design study: many designs' starts in one call (issue 14 item 5); every step is
    elementwise, so a row's result does not depend on the other rows of the batch.
    ``mu`` (scalar or per row) only decides the ``slip`` flag: the sticking model does not depend on it.
    """
    edge = np.asarray(edge, dtype=int)
    radius = np.asarray(radius, dtype=float)
    h = np.broadcast_to(np.asarray(offset, dtype=float), radius.shape)
    w = np.broadcast_to(np.asarray(speed, dtype=float), radius.shape)
    g = float(gravity)
    t, k = earliest_impact(part, edge, radius, 0.0, w, g)
    if (k < 0).any():
        # Cannot happen: by the end of the searched flight the centre of mass is back at arm level.
        raise RuntimeError("flight ended without an impact: the flight bound is wrong")
    x, _, theta, xdot, ydot, phidot = np.moveaxis(flight_state(part, edge, radius, h, w, g, t), -1, 0)
    c, s = np.cos(theta), np.sin(theta)
    rx = c * part.hull[k, 0] - s * part.hull[k, 1]
    ry = s * part.hull[k, 0] + c * part.hull[k, 1]
    xp, yp, omega = sticking_impact(rx, ry, xdot, ydot, phidot, part.rho)
    mus = np.broadcast_to(np.asarray(mu, dtype=float), radius.shape)
    catch_slip = outside_cone(xp - xdot, yp - ydot, mus)
    rest = settle(part, g, k, theta, omega, x + rx, mus)
    theta0 = rest_pose(part, edge, radius, h)[2]
    left = rest.x + part.u_left[np.maximum(rest.edge, 0)]
    return ThrowBatch(
        edge=rest.edge,
        radius=rest.x,
        rotation=rest.theta - theta0,
        flight_time=t,
        impacts=rest.impacts + 1,
        lift_off=rest.lift_off,
        slip=catch_slip | rest.slip,
        off_arm=(np.minimum(rest.contact_min, left) < 0) | (rest.contact_max > arm_length),
        toe_stub=left <= 0,
    )


@dataclass(frozen=True)
class ThrowResult:
    """One application of the throw map from (start_edge, start_radius); SI units."""

    edge: int
    radius: float
    kind: ThrowKind
    rotation: float
    turns: int
    flight_time: float
    impacts: int
    start_edge: int
    start_radius: float
    lift_off: bool = False
    slip: bool = False
    off_arm: bool = False
    toe_stub: bool = False
    fidelity: str = "paper"

    @property
    def violations(self) -> list[str]:
        """Return the names of the assumptions this throw breaks (ASSUMPTIONS order)."""
        return [name for name in ASSUMPTIONS if getattr(self, name)]

    def to_json(self) -> dict[str, Any]:
        """Return the `feeder throw --json` object (contract 3), with the assumption flags."""
        return {
            "edge": self.edge,
            "radius": self.radius,
            "kind": self.kind,
            "start_edge": self.start_edge,
            "start_radius": self.start_radius,
            "rotation": self.rotation,
            "turns": self.turns,
            "flight_time": self.flight_time,
            "impacts": self.impacts,
            "lift_off": self.lift_off,
            "slip": self.slip,
            "off_arm": self.off_arm,
            "toe_stub": self.toe_stub,
            "fidelity": self.fidelity,
        }


def throw(part: ArmPart, edge: int, radius: float, params: ThrowParams) -> ThrowResult:
    """Apply the throw map once, with the domain checked (errors name the field)."""
    check_start(part, edge, radius, params)
    out = throw_batch(part, np.array([edge]), np.array([radius]), params)
    return ThrowResult(
        edge=int(out.edge[0]),
        radius=float(out.radius[0]),
        kind=throw_kind(edge, int(out.edge[0]), float(out.rotation[0])),
        rotation=float(out.rotation[0]),
        turns=int(out.turns[0]),
        flight_time=float(out.flight_time[0]),
        impacts=int(out.impacts[0]),
        start_edge=edge,
        start_radius=radius,
        lift_off=bool(out.flag("lift_off")[0]),
        slip=bool(out.flag("slip")[0]),
        off_arm=bool(out.flag("off_arm")[0]),
        toe_stub=bool(out.flag("toe_stub")[0]),
    )
