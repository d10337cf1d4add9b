"""The convex hull and the diameter function of a polygonal part (Goldberg 1993, section 3).

A frictionless parallel-jaw squeeze sees only the part's convex hull. The diameter function d(theta) is
the distance between two parallel jaws touching the hull, with the part at orientation theta relative
to the gripper (the jaws close along the gripper's x axis). With the hull vertices v_i in the part frame,

    d(theta) = max_i (R(theta) v_i)_x - min_i (R(theta) v_i)_x,

which has period pi. Between two breakpoints (orientations where a hull edge lies flush with a jaw) the
same pair of vertices touches the jaws, so d is one sinusoid there (Goldberg's equation for d on an arc):

    d(theta) = D_k cos(theta - beta_k),   D_k = |v_a - v_b|, beta_k = -arg(v_a - v_b).

Each piece is concave (|theta - beta_k| < pi/2 where it is positive), so a local minimum lies only at a
breakpoint, exactly at an edge normal, and a local maximum only inside a piece, exactly at beta_k. Both
are located analytically here, never on a grid: a shallow minimum whose basin is a thousandth of a
radian is found like any other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner import polygon
from feeder_planner.errors import InputError
from feeder_planner.fields_io import point_array
from feeder_planner.squeeze.tolerances import ANGLE_TOLERANCE, DEGENERATE_AREA_FRACTION

__all__ = ["DiameterFunction", "Extremum", "Piece", "convex_hull", "diameter_function", "wrap"]

TWO_PI = 2.0 * math.pi


def wrap(angle: float, period: float = TWO_PI) -> float:
    """Return ``angle`` reduced into [0, period)."""
    value = math.fmod(angle, period)
    if value < 0.0:
        value += period
    # fmod of a tiny negative angle plus the period rounds to the period itself.
    return 0.0 if value >= period else value + 0.0


def convex_hull(vertices: object, field: str = "vertices") -> np.ndarray:
    """Return the convex hull of a part's outline, counter-clockwise, centred on the hull's vertex mean.

    Refuses, naming ``field``, an outline that is not an array of finite points or whose hull is
    degenerate (a segment or a point: no isolated minimum of the diameter function, so no plan).
    """
    # An outline from a Part arrives as an array; the field reader takes lists (a file's form).
    listed = vertices.tolist() if isinstance(vertices, np.ndarray) else vertices
    points = point_array(listed, field, 2, min_points=3)
    indices = polygon.convex_hull_indices(points)
    span = float(np.ptp(points, axis=0).max())
    hull = points[indices] if len(indices) >= 3 else points[:0]
    area = polygon.signed_area(hull) if len(hull) >= 3 else 0.0
    if len(hull) < 3 or span <= 0.0 or area <= DEGENERATE_AREA_FRACTION * span * span:
        raise InputError(
            field,
            f"the convex hull is degenerate (area {area:.3g} for a span of {span:.3g}): "
            "a squeeze cannot orient a segment or a point",
        )
    return np.asarray(hull - hull.mean(axis=0), dtype=float)


@dataclass(frozen=True)
class Piece:
    """One sinusoidal piece of d on [start, end): d(theta) = amplitude cos(theta - phase)."""

    start: float
    end: float
    amplitude: float
    phase: float

    def value(self, theta: float) -> float:
        """d(theta) on this piece."""
        return self.amplitude * math.cos(theta - self.phase)

    def slope(self, theta: float) -> float:
        """d'(theta) on this piece."""
        return -self.amplitude * math.sin(theta - self.phase)


@dataclass(frozen=True)
class Extremum:
    """A local minimum or maximum of d: its orientation (rad, in [0, pi)) and the width there (m)."""

    angle: float
    width: float
    kind: str  # "min" or "max"


@dataclass(frozen=True)
class DiameterFunction:
    """d(theta) over one period [0, pi) as sinusoidal pieces, with its exact extrema."""

    hull: np.ndarray
    pieces: tuple[Piece, ...]
    minima: tuple[Extremum, ...]
    maxima: tuple[Extremum, ...]

    def __call__(self, theta: float) -> float:
        """Return the jaw width (m) with the part at orientation ``theta`` (rad, any real)."""
        return self.piece_at(theta).value(self._reduced(theta))

    def _reduced(self, theta: float) -> float:
        return self.pieces[0].start + wrap(theta - self.pieces[0].start, math.pi)

    def piece_at(self, theta: float) -> Piece:
        """Return the piece whose arc holds ``theta`` (mod pi)."""
        x = self._reduced(theta)
        for piece in self.pieces:
            if piece.start <= x < piece.end:
                return piece
        return self.pieces[-1]

    def direct(self, theta: float) -> float:
        """d(theta) straight from the hull vertices (the definition), for independent checks."""
        c, s = math.cos(theta), math.sin(theta)
        xs = self.hull[:, 0] * c - self.hull[:, 1] * s
        return float(xs.max() - xs.min())

    def sample(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """D on ``count`` evenly spaced orientations of [0, 2 pi), for plots."""
        thetas = np.linspace(0.0, TWO_PI, count, endpoint=False)
        return thetas, np.array([self(float(t)) for t in thetas])


def _breakpoints(hull: np.ndarray) -> list[float]:
    """Orientations theta in [0, pi) where a hull edge is flush with a jaw, merged within tolerance.

    Edge e has outward normal angle n_e (counter-clockwise hull); it is flush with a jaw when the normal
    is along -+x in the gripper frame, i.e. theta = -n_e (mod pi).
    """
    edges = np.roll(hull, -1, axis=0) - hull
    normals = np.arctan2(-edges[:, 0], edges[:, 1])
    angles = sorted(wrap(-float(n), math.pi) for n in normals)
    merged: list[float] = []
    for angle in angles:
        if not merged or angle - merged[-1] > ANGLE_TOLERANCE:
            merged.append(angle)
    if len(merged) > 1 and merged[0] + math.pi - merged[-1] <= ANGLE_TOLERANCE:
        merged.pop()
    return merged


def _piece(hull: np.ndarray, start: float, end: float) -> Piece:
    """Return the sinusoid on [start, end): the vertices touching the jaws at the arc's middle."""
    middle = 0.5 * (start + end)
    c, s = math.cos(middle), math.sin(middle)
    xs = hull[:, 0] * c - hull[:, 1] * s
    chord = hull[int(np.argmax(xs))] - hull[int(np.argmin(xs))]
    amplitude = float(math.hypot(chord[0], chord[1]))
    # (R(theta) chord)_x = |chord| cos(theta + arg chord): the phase is -arg chord, taken nearest the arc.
    phase = -math.atan2(float(chord[1]), float(chord[0]))
    phase = middle + math.remainder(phase - middle, TWO_PI)
    return Piece(start, end, amplitude, phase)


def _trends(piece: Piece) -> list[str]:
    """Return the monotone runs of a piece: rising to its crest at ``phase``, then falling."""
    if piece.phase <= piece.start + ANGLE_TOLERANCE:
        return ["fall"]
    if piece.phase >= piece.end - ANGLE_TOLERANCE:
        return ["rise"]
    return ["rise", "fall"]


def diameter_function(vertices: object, field: str = "vertices") -> DiameterFunction:
    """Build d(theta) of a part outline (any simple polygon: only its hull matters).

    The extrema come from the runs of the pieces: a fall followed by a rise is a minimum, at the
    breakpoint between them; a rise followed by a fall is a maximum, at the crest inside a piece (or, when
    the crest is within ANGLE_TOLERANCE of a breakpoint, at the breakpoint). A piece whose crest lies at
    its end (a right-angled corner whose vertex is opposite the flush edge) is a shoulder, not an
    extremum: the part passes through it.
    """
    hull = convex_hull(vertices, field)
    cuts = _breakpoints(hull)
    bounds = [*cuts, cuts[0] + math.pi]
    pieces = tuple(_piece(hull, bounds[k], bounds[k + 1]) for k in range(len(cuts)))
    minima: list[Extremum] = []
    maxima: list[Extremum] = []
    previous = _trends(pieces[-1])[-1]
    for piece in pieces:
        runs = _trends(piece)
        if previous == "fall" and runs[0] == "rise":
            minima.append(Extremum(wrap(piece.start, math.pi), piece.value(piece.start), "min"))
        elif previous == "rise" and runs[0] == "fall":
            maxima.append(Extremum(wrap(piece.start, math.pi), piece.value(piece.start), "max"))
        if len(runs) == 2:
            maxima.append(Extremum(wrap(piece.phase, math.pi), piece.amplitude, "max"))
        previous = runs[-1]
    minima.sort(key=lambda e: e.angle)
    maxima.sort(key=lambda e: e.angle)
    if not minima or len(minima) != len(maxima):
        # Unreachable for a hull of positive area (d is not constant and has period pi); kept so that a
        # broken invariant is named rather than returned.
        raise InputError(field, f"the diameter function has {len(minima)} minima and {len(maxima)} maxima")
    return DiameterFunction(hull=hull, pieces=pieces, minima=tuple(minima), maxima=tuple(maxima))
