"""The throw map f: (i0, R0) -> (i1, R1) of section III-C (impulsive throw, flight, sticking catch, settling)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.throwing.flight import earliest_impact
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.grasp import grasp_radius
from feeder_planner.throwing.impact import sticking_impact
from feeder_planner.throwing.rolling import TWO_PI, settle

GRASP_TOL = 1e-12  # relative slack on R >= R_grasp, so that R exactly at R_grasp is accepted


@dataclass(frozen=True)
class ThrowParams:
    """Design parameters: offset h (m), release speed W (rad/s), gravity g (m/s^2, < 0), friction mu."""

    offset: float
    speed: float
    gravity: float
    mu: float

    def __post_init__(self) -> None:
        for name, value in (
            ("offset", self.offset),
            ("release_speed", self.speed),
            ("gravity", self.gravity),
            ("mu", self.mu),
        ):
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise InputError(name, f"must be a finite number, got {value!r}")
        if self.gravity >= 0:
            raise InputError("gravity", f"must be < 0 (gravity pulls along -y), got {self.gravity!r}")
        if self.speed <= 0:
            raise InputError("release_speed", f"must be > 0 (counter-clockwise throw), got {self.speed!r}")
        if self.mu <= 0:
            raise InputError("mu", f"must be > 0, got {self.mu!r}")


@dataclass
class ThrowBatch:
    """Results of a batch of throws."""

    edge: np.ndarray  # i1
    radius: np.ndarray  # R1 (m)
    rotation: np.ndarray  # net rotation of the part over flight and settling (rad, counter-clockwise +)
    flight_time: np.ndarray
    impacts: np.ndarray

    @property
    def turns(self) -> np.ndarray:
        """Whole turns contained in the net rotation (toward zero)."""
        return np.trunc(self.rotation / TWO_PI + np.sign(self.rotation) * 1e-9).astype(int)

    def is_jog(self, start_edge: np.ndarray) -> np.ndarray:
        """Jog: same edge and zero net rotation; anything else is a flip (section III-C)."""
        return (self.edge == start_edge) & (np.abs(self.rotation) < math.pi)


def lowest_radius(part: ArmPart, edge: int, params: ThrowParams) -> float:
    """Smallest throwable R: R_grasp, and the left contact vertex right of the pivot (no stubbed toe)."""
    return max(grasp_radius(part, edge, params.offset, params.mu), -float(part.u_left[edge]))


def check_start(part: ArmPart, edge: int, radius: float, params: ThrowParams) -> None:
    """Refuse a start outside the map's domain: unstable edge, R below R_grasp, or a stubbed toe."""
    if not (0 <= edge < part.n):
        raise InputError("edge", f"no hull edge {edge} (the hull has edges 0..{part.n - 1})")
    if not math.isfinite(radius):
        raise InputError("radius", f"must be finite, got {radius!r}")
    r_grasp = grasp_radius(part, edge, params.offset, params.mu)  # raises for an unstable edge
    if radius < r_grasp - GRASP_TOL * max(1.0, abs(r_grasp)):
        raise InputError(
            "radius",
            f"R = {radius:.6g} m is below R_grasp = {r_grasp:.6g} m of edge {edge}: "
            "the impulsive throw is not in a dynamic grasp (eqs. 1-4)",
        )
    if radius + float(part.u_left[edge]) <= 0:
        raise InputError(
            "radius",
            f"R = {radius:.6g} m puts the left contact vertex left of the pivot: it would "
            "move into the arm at release (the paper assumes the part right of the pivot)",
        )


def throw_batch(part: ArmPart, edge: np.ndarray, radius: np.ndarray, params: ThrowParams) -> ThrowBatch:
    """Apply f to every (edge[b], radius[b]) at once (callers have checked the domain)."""
    edge = np.asarray(edge, dtype=int)
    radius = np.asarray(radius, dtype=float)
    w, g, h = params.speed, params.gravity, params.offset
    t, k = earliest_impact(part, edge, radius, h, w, g)
    if (k < 0).any():
        raise RuntimeError(
            "flight ended without an impact: the flight bound is wrong"
        )  # cannot happen: CM at arm level
    a = h + part.d[edge]
    theta0 = -part.edge_angle[edge]
    theta = theta0 + w * t
    x = radius - a * w * t
    xdot, ydot = -a * w, radius * w + g * t
    c, s = np.cos(theta), np.sin(theta)
    rx = c * part.hull[k, 0] - s * part.hull[k, 1]
    ry = s * part.hull[k, 0] + c * part.hull[k, 1]
    _, _, omega = sticking_impact(rx, ry, xdot, ydot, np.full_like(t, w), part.rho)
    rest = settle(part, g, k, theta, omega, x + rx)
    return ThrowBatch(
        edge=rest.edge, radius=rest.x, rotation=rest.theta - theta0, flight_time=t, impacts=rest.impacts + 1
    )


@dataclass(frozen=True)
class ThrowResult:
    edge: int
    radius: float
    kind: str
    rotation: float
    turns: int
    flight_time: float
    impacts: int


def throw(part: ArmPart, edge: int, radius: float, params: ThrowParams) -> ThrowResult:
    """One application of the throw map, with the domain checked (errors name the field)."""
    check_start(part, edge, radius, params)
    out = throw_batch(part, np.array([edge]), np.array([radius]), params)
    kind = "jog" if bool(out.is_jog(np.array([edge]))[0]) else "flip"
    return ThrowResult(
        edge=int(out.edge[0]),
        radius=float(out.radius[0]),
        kind=kind,
        rotation=float(out.rotation[0]),
        turns=int(out.turns[0]),
        flight_time=float(out.flight_time[0]),
        impacts=int(out.impacts[0]),
    )
