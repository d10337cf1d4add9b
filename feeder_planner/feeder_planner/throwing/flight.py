"""Free flight after an impulsive release, eqs. (5) and (6), and the certified earliest impact on the arm."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.tolerances import IMPACT_BISECTIONS

__all__ = ["rest_pose", "flight_state", "vertex_positions", "earliest_impact"]

Pose = tuple[np.ndarray, np.ndarray, np.ndarray]
# A release speed: one for the batch, or one per throw (or per piece) of a design study.
Speed = float | np.ndarray


def rest_pose(
    part: ArmPart, edge: np.ndarray | int, radius: np.ndarray | float, offset: float | np.ndarray
) -> Pose:
    """Return (x, y, Theta) of the centre of mass resting on ``edge`` at R = ``radius``: eq. (5) at t = 0.

    The centre of mass lies d^i above the arm surface y = h, and the part's absolute angle is
    Theta = -alpha_i (edge i's direction turned flat). Broadcasts over arrays of edges and radii.
    """
    edge = np.asarray(edge)
    return np.asarray(radius, dtype=float), offset + part.d[edge], -part.edge_angle[edge]


def flight_state(
    part: ArmPart,
    edge: np.ndarray | int,
    radius: np.ndarray | float,
    offset: float | np.ndarray,
    speed: float | np.ndarray,
    gravity: float,
    t: np.ndarray,
) -> np.ndarray:
    """Return rows (x, y, Theta, xdot, ydot, Thetadot) at times t after release, eq. (5).

    Theta = -alpha_i + phi is the part's absolute angle. ``edge``, ``radius``, ``t`` (and per-row
    ``offset`` and ``speed`` of a design study) broadcast against each other: one start at many times,
    or a batch of starts each at its own time.
    """
    t = np.asarray(t, dtype=float)
    x0, a, theta0 = rest_pose(part, edge, radius, offset)  # a = h + d^i, the height of the centre of mass
    columns = (
        x0 - a * speed * t,
        a + x0 * speed * t + 0.5 * gravity * t * t,
        theta0 + speed * t,
        -a * speed,
        x0 * speed + gravity * t,
        speed,
    )
    # Filled column by column with numpy's own broadcasting: this runs once per batch of throws, and
    # broadcast_to + stack per column cost a measurable part of a limit set.
    state = np.empty((*np.broadcast_shapes(*(np.shape(col) for col in columns)), len(columns)))
    for k, column in enumerate(columns):
        state[..., k] = column
    return state


def vertex_positions(
    part: ArmPart, edge: int, radius: float, offset: float, speed: float, gravity: float, t: float
) -> np.ndarray:
    """Return the hull vertices in the arm frame at time t of flight, eq. (6)."""
    x, y, theta = flight_state(part, edge, radius, offset, speed, gravity, np.array([t]))[0, :3]
    c, s = math.cos(theta), math.sin(theta)
    return part.hull @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def _height(
    t: np.ndarray, d: np.ndarray, b: np.ndarray, s: np.ndarray, c: np.ndarray, w: Speed, g: float
) -> np.ndarray:
    """Return f(t) = d + b t + g t^2/2 + s sin(W t + c): a vertex's height above the arm, eqs. (5), (6)."""
    return d + t * (b + 0.5 * g * t) + s * np.sin(w * t + c)


def _rate(t: np.ndarray, b: np.ndarray, s: np.ndarray, c: np.ndarray, w: Speed, g: float) -> np.ndarray:
    """Return f'(t) = b + g t + W s cos(W t + c)."""
    return b + g * t + w * s * np.cos(w * t + c)


def _bisect(
    lo: np.ndarray,
    hi: np.ndarray,
    go_right: Callable[[np.ndarray], np.ndarray],
    step: int = IMPACT_BISECTIONS,
) -> tuple[np.ndarray, np.ndarray]:
    """Halve every bracket [lo, hi] ``step`` times; ``go_right(mid)`` says where the sought point is not."""
    for _ in range(step):
        mid = 0.5 * (lo + hi)
        right = go_right(mid)
        lo, hi = np.where(right, mid, lo), np.where(right, hi, mid)
    return lo, hi


@dataclass(frozen=True)
class _Pieces:
    """Pieces [lo, hi] of the flight on which one vertex's height is convex or concave, flattened.

    Entry j belongs to throw ``throw[j]`` and hull vertex ``vertex[j]``; ``d``, ``b``, ``s``, ``c`` are
    the coefficients of that vertex's height f (see ``_height``), ``w`` its throw's release speed.
    """

    w: np.ndarray
    throw: np.ndarray
    vertex: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    d: np.ndarray
    b: np.ndarray
    s: np.ndarray
    c: np.ndarray


def _flight_end(d: np.ndarray, b: np.ndarray, g: float) -> np.ndarray:
    """Return T, when the centre of mass is back at arm level: the root of d + b t + g t^2/2 (eq. 5)."""
    return (b + np.sqrt(b * b - 2.0 * g * d)) / (-g)


def _pieces(
    d: np.ndarray, b: np.ndarray, s: np.ndarray, c: np.ndarray, w: Speed, g: float, t_end: np.ndarray
) -> _Pieces:
    """Cut each throw's flight [0, T] at the inflection points of every vertex's height.

    f'' = g - W^2 s sin(W t + c) vanishes where sin(W t + c) = g / (W^2 s); there is none when
    W^2 s <= |g| (f concave throughout). Shapes: d, b, w, t_end (B, 1); s (1, n); c (B, n).
    """
    batch, n = c.shape
    w = np.broadcast_to(np.asarray(w, dtype=float), (batch, 1))
    sigma = np.clip(g / (w * w * s), -1.0, 1.0)  # (B, n)
    has_inflection = w * w * s > -g  # (B, n)
    ends = [np.zeros((batch, n, 1)), np.broadcast_to(t_end[..., None], (batch, n, 1))]
    if has_inflection.any():
        turns = int(math.ceil(float((w * t_end).max()) / (2 * math.pi))) + 1
        phases = np.stack([np.arcsin(sigma), math.pi - np.arcsin(sigma)], axis=0)  # (2, B, n)
        first = np.mod(phases - c[None, :, :], 2 * math.pi) / w[None]  # (2, B, n)
        cuts = first[..., None] + (2 * math.pi / w)[None, :, :, None] * np.arange(turns)  # (2, B, n, J)
        cuts = np.moveaxis(cuts, 0, -2).reshape(batch, n, -1)
        cuts = np.where(has_inflection[:, :, None], cuts, np.inf)
        ends.insert(1, np.minimum(cuts, t_end[..., None]))
    bounds = np.sort(np.concatenate(ends, axis=-1), axis=-1)
    lo, hi = bounds[..., :-1], bounds[..., 1:]  # (B, n, P)
    bi, ki, pi = np.nonzero(hi > lo)
    return _Pieces(w[bi, 0], bi, ki, lo[bi, ki, pi], hi[bi, ki, pi], d[bi, 0], b[bi, 0], s[0, ki], c[bi, ki])


def _piece_minima(p: _Pieces, g: float) -> np.ndarray:
    """Return the point m of each piece where its first crossing must show: f(m) <= 0 iff f crosses there.

    On a convex piece m is the minimum of f (where f' = 0, or an end); on a concave piece, which f enters
    positive and can cross at most once, it is the right end.
    """
    w = p.w
    mid = 0.5 * (p.lo + p.hi)
    convex = (g - w * w * p.s * np.sin(w * mid + p.c)) > 0
    m = p.hi.copy()
    rate_lo, rate_hi = _rate(p.lo, p.b, p.s, p.c, w, g), _rate(p.hi, p.b, p.s, p.c, w, g)
    m = np.where(convex & (rate_lo >= 0), p.lo, m)
    inner = np.flatnonzero(convex & (rate_lo < 0) & (rate_hi > 0))
    if inner.size:
        b, s, c, wi = p.b[inner], p.s[inner], p.c[inner], w[inner]
        _, m[inner] = _bisect(p.lo[inner].copy(), p.hi[inner].copy(), lambda t: _rate(t, b, s, c, wi, g) < 0)
    return m


def _first_crossings(p: _Pieces, m: np.ndarray, g: float, batch: int) -> tuple[np.ndarray, np.ndarray]:
    """Return (t*, k*) per throw: bisect f = 0 on the pieces that can hold the earliest root, keep the first.

    A piece holds a sure crossing when f(m) <= 0 at its minimum m; only pieces starting before the
    earliest such m can hold the first root, and on each f falls from positive to m at most once.
    """
    candidate = (_height(m, p.d, p.b, p.s, p.c, p.w, g) <= 0) & (m > 0)
    best_m = np.full(batch, np.inf)
    np.minimum.at(best_m, p.throw[candidate], m[candidate])
    keep = np.flatnonzero(candidate & (p.lo <= best_m[p.throw]))
    d, b, s, c, w = p.d[keep], p.b[keep], p.s[keep], p.c[keep], p.w[keep]
    _, hit = _bisect(p.lo[keep].copy(), m[keep].copy(), lambda t: _height(t, d, b, s, c, w, g) > 0)
    throw = p.throw[keep]
    t_hit = np.full(batch, np.inf)
    np.minimum.at(t_hit, throw, hit)
    owner = np.full(batch, -1)
    winner = hit <= t_hit[throw]
    owner[throw[winner]] = p.vertex[keep][winner]
    return t_hit, owner


def earliest_impact(
    part: ArmPart, edge: np.ndarray, radius: np.ndarray, offset: float, speed: Speed, gravity: float
) -> tuple[np.ndarray, np.ndarray]:
    """Return (t*, k*): the first time t > 0 a hull vertex reaches the arm surface y = h, and which vertex.

    Vertex k's height above the arm is f(t) = d + R W t + g t^2/2 + s_k sin(W t + c_k) (eqs. 5, 6), with
    f'' = g - W^2 s_k sin(W t + c_k). The flight [0, T] (T: the centre of mass back at arm level,
    after which an impact has surely happened) is cut at the inflection points of every f, so each
    piece is convex or concave. On a concave piece f is positive then negative; on a convex piece it
    decreases to its minimum (found by bisection on the monotone f') then increases. Hence at most one
    first crossing per piece, found by bisection: no root is missed however often the part turns.
    Tolerance: the impact time is exact to 2^-IMPACT_BISECTIONS of the flight time. The contact vertices
    start at f(0) = 0 with f'(0) = W (R + u) > 0 (the caller has ruled out a stubbed toe). ``speed``
    is one W for the batch or one per throw (a design study's rows, issue 14 item 5).
    """
    edge = np.asarray(edge)
    radius = np.asarray(radius, dtype=float)
    g = float(gravity)
    w = np.broadcast_to(np.asarray(speed, dtype=float), radius.shape)[:, None]  # (B, 1)
    d = part.d[edge][:, None]  # (B, 1)
    b = radius[:, None] * w
    q = part.hull
    s = np.hypot(q[:, 0], q[:, 1])[None, :]  # (1, n)
    c = np.arctan2(q[:, 1], q[:, 0])[None, :] - part.edge_angle[edge][:, None]  # (B, n)
    pieces = _pieces(d, b, s, c, w, g, _flight_end(d, b, g))
    return _first_crossings(pieces, _piece_minima(pieces, g), g, len(radius))
