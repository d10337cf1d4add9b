"""Free flight after an impulsive release, eqs. (5) and (6), and the certified earliest impact with the arm."""

from __future__ import annotations

import math

import numpy as np

from feeder_planner.throwing.geometry import ArmPart

_BISECTIONS = 60  # halvings of a piece: 2^-60 of the flight time is below double resolution


def release_state(
    part: ArmPart, edge: np.ndarray, radius: np.ndarray, offset: float, speed: float
) -> tuple[np.ndarray, ...]:
    """(x, y, Theta, xdot, ydot, Thetadot) at release, eq. (5) at t = 0; Theta is the part's absolute angle."""
    a = offset + part.d[edge]
    return (
        radius.astype(float),
        a,
        -part.edge_angle[edge],
        -a * speed,
        radius * speed,
        np.full(radius.shape, float(speed)),
    )


def flight_state(
    part: ArmPart, edge: int, radius: float, offset: float, speed: float, gravity: float, t: np.ndarray
) -> np.ndarray:
    """Rows (x, y, Theta, xdot, ydot, Thetadot) at times t, eq. (5) (Theta = -alpha_i + phi)."""
    t = np.asarray(t, dtype=float)
    a = offset + float(part.d[edge])
    return np.stack(
        [
            radius - a * speed * t,
            a + radius * speed * t + 0.5 * gravity * t * t,
            -float(part.edge_angle[edge]) + speed * t,
            np.full_like(t, -a * speed),
            radius * speed + gravity * t,
            np.full_like(t, speed),
        ],
        axis=-1,
    )


def vertex_positions(
    part: ArmPart, edge: int, radius: float, offset: float, speed: float, gravity: float, t: float
) -> np.ndarray:
    """Hull vertices in the arm frame at time t of flight, eq. (6)."""
    x, y, theta = flight_state(part, edge, radius, offset, speed, gravity, np.array([t]))[0, :3]
    c, s = math.cos(theta), math.sin(theta)
    return part.hull @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def earliest_impact(
    part: ArmPart, edge: np.ndarray, radius: np.ndarray, offset: float, speed: float, gravity: float
) -> tuple[np.ndarray, np.ndarray]:
    """(t*, k*): the first time t > 0 a hull vertex reaches the arm surface y = h, and which vertex.

    Vertex k's height above the arm is f(t) = d + R W t + g t^2/2 + s_k sin(W t + c_k), with
    f'' = g - W^2 s_k sin(W t + c_k). The flight [0, T] (T: the centre of mass back at arm level,
    after which an impact has surely happened) is cut at the inflection points of every f, so each
    piece is convex or concave. On a concave piece f is positive then negative; on a convex piece it
    decreases to its minimum (found by bisection on the monotone f') then increases. Hence at most one
    first crossing per piece, found by bisection: no root is missed however often the part turns.
    Tolerance: the impact time is exact to 2^-60 of the flight time. The contact vertices start at
    f(0) = 0 with f'(0) = W (R + u) > 0 (the caller has ruled out a stubbed toe).
    """
    edge = np.asarray(edge)
    radius = np.asarray(radius, dtype=float)
    w, g = float(speed), float(gravity)
    d = part.d[edge][:, None]  # (B, 1)
    b1 = (radius * w)[:, None]
    q = part.hull
    s = np.hypot(q[:, 0], q[:, 1])[None, :]  # (1, n)
    c = np.arctan2(q[:, 1], q[:, 0])[None, :] - part.edge_angle[edge][:, None]  # (B, n)
    t_end = (b1 + np.sqrt(b1 * b1 - 2.0 * g * d)) / (-g)  # (B, 1)

    def f(t: np.ndarray, d_: np.ndarray, b_: np.ndarray, s_: np.ndarray, c_: np.ndarray) -> np.ndarray:
        return d_ + t * (b_ + 0.5 * g * t) + s_ * np.sin(w * t + c_)

    def fp(t: np.ndarray, b_: np.ndarray, s_: np.ndarray, c_: np.ndarray) -> np.ndarray:
        return b_ + g * t + w * s_ * np.cos(w * t + c_)

    # Inflection times: sin(W t + c) = g / (W^2 s); none when W^2 s <= |g| (f concave throughout).
    sigma = np.clip(g / (w * w * s), -1.0, 1.0)
    has_inflection = (w * w * s > -g)[0]  # (n,)
    batch, n = len(radius), len(q)
    edges_ = [np.zeros((batch, n, 1)), np.broadcast_to(t_end[..., None], (batch, n, 1))]
    if has_inflection.any():
        turns = int(math.ceil(w * float(t_end.max()) / (2 * math.pi))) + 1
        phases = np.concatenate([np.arcsin(sigma), math.pi - np.arcsin(sigma)], axis=0)  # (2, n)
        first = np.mod(phases[:, None, :] - c[None, :, :], 2 * math.pi) / w  # (2, B, n)
        cuts = first[..., None] + (2 * math.pi / w) * np.arange(turns)  # (2, B, n, J)
        cuts = np.moveaxis(cuts, 0, -2).reshape(batch, n, -1)
        cuts = np.where(has_inflection[None, :, None], cuts, np.inf)
        edges_.insert(1, np.minimum(cuts, t_end[..., None]))
    bounds = np.sort(np.concatenate(edges_, axis=-1), axis=-1)
    a_, b_ = bounds[..., :-1], bounds[..., 1:]  # pieces (B, n, P)
    bi, ki, pi = np.nonzero(b_ > a_)
    a_, b_ = a_[bi, ki, pi], b_[bi, ki, pi]
    dd, bb, ss, cc = d[bi, 0], b1[bi, 0], s[0, ki], c[bi, ki]
    mid = 0.5 * (a_ + b_)
    convex = (g - w * w * ss * np.sin(w * mid + cc)) > 0
    # Minimum point m of each piece: b on concave pieces, where f' = 0 (or an end) on convex ones.
    m = b_.copy()
    fpa, fpb = fp(a_, bb, ss, cc), fp(b_, bb, ss, cc)
    m = np.where(convex & (fpa >= 0), a_, m)
    inner = np.flatnonzero(convex & (fpa < 0) & (fpb > 0))
    if inner.size:
        lo, hi = a_[inner].copy(), b_[inner].copy()
        bb_i, ss_i, cc_i = bb[inner], ss[inner], cc[inner]
        for _ in range(_BISECTIONS):
            mm = 0.5 * (lo + hi)
            neg = fp(mm, bb_i, ss_i, cc_i) < 0
            lo, hi = np.where(neg, mm, lo), np.where(neg, hi, mm)
        m[inner] = hi
    candidate = (f(m, dd, bb, ss, cc) <= 0) & (m > 0)
    # Only pieces that can hold the earliest root: start before the earliest sure crossing m.
    batch = len(radius)
    best_m = np.full(batch, np.inf)
    np.minimum.at(best_m, bi[candidate], m[candidate])
    keep = np.flatnonzero(candidate & (a_ <= best_m[bi]))
    lo, hi = a_[keep].copy(), m[keep].copy()
    dk, bk, sk, ck = dd[keep], bb[keep], ss[keep], cc[keep]
    for _ in range(_BISECTIONS):
        mm = 0.5 * (lo + hi)
        pos = f(mm, dk, bk, sk, ck) > 0
        lo, hi = np.where(pos, mm, lo), np.where(pos, hi, mm)
    t_hit = np.full(batch, np.inf)
    np.minimum.at(t_hit, bi[keep], hi)
    owner = np.full(batch, -1)
    winner = hi <= t_hit[bi[keep]]
    owner[bi[keep][winner]] = ki[keep][winner]
    return t_hit, owner
