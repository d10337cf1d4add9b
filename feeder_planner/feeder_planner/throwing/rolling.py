"""Rolling about the impact vertex under gravity, the next sticking impact, and settling (section III-B)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.impact import sticking_impact
from feeder_planner.throwing.tolerances import FLAT_ANGLE, MAX_IMPACTS

__all__ = ["Settled", "settle", "lift_off_in_swing", "outside_cone"]

TWO_PI = 2 * math.pi


@dataclass(frozen=True)
class Settled:
    """Where each part of a batch came to rest: edge, centre-of-mass x, absolute angle, impacts taken.

    Also the assumptions the sticking-catch-and-roll model made on the way (issue 14 item 2): ``lift_off``
    (the pivot's normal force would turn negative in some swing), ``slip`` (a strike's impulse lies
    outside the friction cone of mu), and the smallest and largest x of any contact point (pivots and
    struck vertices), so that the caller can tell a part rolling off the arm.
    """

    edge: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    impacts: np.ndarray
    lift_off: np.ndarray
    slip: np.ndarray
    contact_min: np.ndarray
    contact_max: np.ndarray


class _Geometry:
    """Per-vertex arrays the vectorised rolling needs."""

    def __init__(self, part: ArmPart) -> None:
        q = part.hull
        self.n = part.n
        self.qx, self.qy = q[:, 0], q[:, 1]
        self.s2 = self.qx**2 + self.qy**2
        self.gamma = np.arctan2(self.qy, self.qx)
        self.alpha = part.edge_angle
        self.ext = part.exterior
        self.stable = part.stable
        self.rho = part.rho
        self.inertia = part.rho**2 + self.s2  # about a vertex, per unit mass


def _offset(geo: _Geometry, k: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """How far theta is past the angle at which edge k lies flat, within vertex k's interval [0, ext_k]."""
    ext = geo.ext[k]
    off = np.mod(theta + geo.alpha[k], TWO_PI)
    off = np.where(off > 0.5 * (ext + TWO_PI), off - TWO_PI, off)
    return np.clip(off, 0.0, ext)


def _height(geo: _Geometry, k: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Height c_y of the centre of mass above pivot vertex k."""
    return -(np.sin(theta) * geo.qx[k] + np.cos(theta) * geo.qy[k])


def _cm_dx(geo: _Geometry, k: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """c_x: centre of mass x minus pivot vertex k's x."""
    return -(np.cos(theta) * geo.qx[k] - np.sin(theta) * geo.qy[k])


def _path_peak(geo: _Geometry, k: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Highest c_y about pivot k on the rotation from ``start`` to ``end``."""
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    top = np.mod(-0.5 * math.pi - geo.gamma[k] - lo, TWO_PI) <= (hi - lo)
    peak = np.maximum(_height(geo, k, start), _height(geo, k, end))
    return np.where(top, np.sqrt(geo.s2[k]), peak)


def _interval(geo: _Geometry, k: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (offset, lo, hi): theta's offset in pivot k's angular interval and the interval's ends."""
    off = _offset(geo, k, theta)
    lo = theta - off
    return off, lo, lo + geo.ext[k]


def _pivot(
    geo: _Geometry, k: np.ndarray, theta: np.ndarray, omega: np.ndarray, pivot_x: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (pivot vertex, its x, direction of rotation +-1) for the next swing.

    The direction is the motion's, or from rest that of the gravity torque g c_x / I. A part at rest
    on a flat edge that would rotate into the arm pivots about the edge's other vertex instead.
    """
    off, _, _ = _interval(geo, k, theta)
    ext = geo.ext[k]
    cx = _cm_dx(geo, k, theta)
    direction = np.where(omega != 0, np.sign(omega), np.where(cx > 0, -1.0, 1.0))
    at_lo, at_hi = off <= FLAT_ANGLE, off >= ext - FLAT_ANGLE
    swap_up = (omega == 0) & at_lo & (direction < 0)
    swap_down = (omega == 0) & at_hi & (direction > 0)
    if swap_up.any() or swap_down.any():
        cm_x = pivot_x + cx
        k = np.where(swap_up, (k + 1) % geo.n, np.where(swap_down, (k - 1) % geo.n, k))
        pivot_x = np.where(swap_up | swap_down, cm_x - _cm_dx(geo, k, theta), pivot_x)
    return k, pivot_x, direction


def _swing(
    geo: _Geometry,
    g: float,
    k: np.ndarray,
    theta: np.ndarray,
    omega: np.ndarray,
    direction: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return (direction, end angle, c_y there, omega there) of the rotation about pivot k.

    Energy E = I_k omega^2 / 2 - g c_y is conserved: the part reaches the interval's end in its direction
    if E clears the highest potential on the way (or the way is downhill), else it swings back to the
    other end.
    """
    inertia = geo.inertia[k]
    kinetic = 0.5 * inertia * omega * omega
    h0 = _height(geo, k, theta)
    target = np.where(direction > 0, hi, lo)
    peak = _path_peak(geo, k, theta, target)
    h_target = _height(geo, k, target)
    downhill = (peak <= h0) & (h_target <= h0)
    reach = downhill | (kinetic > -g * (peak - h0))
    direction = np.where(reach, direction, -direction)
    target = np.where(reach, target, np.where(direction > 0, hi, lo))
    h_target = _height(geo, k, target)
    speed2 = np.maximum(2.0 * (kinetic + g * (h_target - h0)) / inertia, 0.0)
    return direction, target, h_target, direction * np.sqrt(speed2)


def lift_off_in_swing(
    rho: float, g: float, energy: np.ndarray, cy_lo: np.ndarray, cy_hi: np.ndarray
) -> np.ndarray:
    """Return whether the pivot's normal force turns negative for some c_y in [cy_lo, cy_hi] of a swing.

    Rolling about a fixed pivot (per unit mass, I = rho^2 + s^2, alpha = g c_x / I, and
    I omega^2 / 2 - g c_y = E), the vertical reaction is N = a_y - g = (-g rho^2 - 2 E c_y - 3 g c_y^2) / I:
    a convex quadratic in c_y (g < 0) with its least value -g rho^2 - E^2 / (-3 g) at c_y* = E / (-3 g).
    The paper's rolling (section III-B) holds only while N >= 0; where N < 0 the part would hop.
    """
    at = np.clip(energy / (-3.0 * g), cy_lo, cy_hi)
    return (-g * rho * rho - 2.0 * energy * at - 3.0 * g * at * at) < 0


def _strike(
    geo: _Geometry,
    k: np.ndarray,
    direction: np.ndarray,
    target: np.ndarray,
    h_target: np.ndarray,
    omega: np.ndarray,
    pivot_x: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return (struck vertex j, flat edge e, centre of mass x, omega after, j's x) at the end of a swing.

    The neighbouring vertex j strikes the arm with edge e now flat: a sticking impact, eqs. (7)-(9).
    If j's velocity after it would push the other vertex of e into the arm, both stick (omega = 0).
    """
    j = np.where(direction > 0, (k - 1) % geo.n, (k + 1) % geo.n)
    e = np.where(direction > 0, (k - 1) % geo.n, k)
    c, s = np.cos(target), np.sin(target)
    cx_t = -(c * geo.qx[k] - s * geo.qy[k])
    cm_x = pivot_x + cx_t
    vx, vy = -omega * h_target, omega * cx_t
    rx = c * geo.qx[j] - s * geo.qy[j]
    ry = s * geo.qx[j] + c * geo.qy[j]
    _, _, om_new = sticking_impact(rx, ry, vx, vy, omega, geo.rho)
    into_arm = np.where(direction > 0, om_new < 0, om_new > 0)
    return j, e, cm_x, np.where(into_arm, 0.0, om_new), cm_x + rx


def _strike_slip(
    geo: _Geometry,
    k: np.ndarray,
    j: np.ndarray,
    target: np.ndarray,
    h_target: np.ndarray,
    omega: np.ndarray,
    om_new: np.ndarray,
    mu: float | np.ndarray,
) -> np.ndarray:
    """Return whether the strike of ``_strike`` needs an impulse outside the friction cone of mu.

    Before: rotation ``omega`` about pivot k; after: ``om_new`` about the struck vertex j, whose
    centre-of-mass velocity is (ry, -rx) omega+ (eqs. 7, 8). The impulse is the change of velocity.
    """
    c, s = np.cos(target), np.sin(target)
    cx_t = -(c * geo.qx[k] - s * geo.qy[k])
    rx = c * geo.qx[j] - s * geo.qy[j]
    ry = s * geo.qx[j] + c * geo.qy[j]
    return outside_cone(ry * om_new + omega * h_target, -rx * om_new - omega * cx_t, mu)


def outside_cone(j_t: np.ndarray, j_n: np.ndarray, mu: float | np.ndarray) -> np.ndarray:
    """Return whether an impulse (tangential j_t, normal j_n on the part) leaves the Coulomb cone of mu.

    A sticking impact needs j_n > 0 and |j_t| <= mu j_n (Coulomb's law for impulses, e.g. Stronge,
    Impact Mechanics, ch. 3); the paper assumes friction "sufficiently high" (section III-B).
    """
    return (j_n <= 0) | (np.abs(j_t) > mu * j_n)


def _settled(
    geo: _Geometry,
    g: float,
    k: np.ndarray,
    j: np.ndarray,
    e: np.ndarray,
    direction: np.ndarray,
    target: np.ndarray,
    h_target: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    omega: np.ndarray,
) -> np.ndarray:
    """Return whether the part has settled on edge e: stable, and too little energy to tip over either vertex.

    Every later impact only removes energy, so a part below both barriers (about j onward, about k back)
    stays on e.
    """
    kinetic = 0.5 * geo.inertia[j] * omega * omega
    off_j = _offset(geo, j, target)
    far_j = np.where(direction > 0, target - off_j + geo.ext[j], target - off_j)
    barrier_j = -g * (_path_peak(geo, j, target, far_j) - _height(geo, j, target))
    far_k = np.where(direction > 0, lo, hi)
    barrier_k = -g * (_path_peak(geo, k, target, far_k) - h_target)
    return geo.stable[e] & (kinetic < np.minimum(barrier_j, barrier_k))


def settle(
    part: ArmPart,
    gravity: float,
    k: np.ndarray,
    theta: np.ndarray,
    omega: np.ndarray,
    pivot_x: np.ndarray,
    mu: float | np.ndarray = math.inf,
) -> Settled:
    """Roll each part about its pivot vertex until it settles on an edge it can no longer escape (III-B).

    Rolling about vertex k conserves E = I_k omega^2 / 2 - g c_y (per unit mass, I_k = rho^2 + |q_k|^2).
    Each round is one swing (``_pivot``, ``_swing``) ended by the strike of the next vertex (``_strike``,
    a sticking impact, eqs. 7-9), after which the part may have settled (``_settled``). Each swing and
    strike is checked against the model's assumptions (``lift_off_in_swing``, ``outside_cone`` with
    ``mu``, a scalar or one per part; the default, infinite mu, never flags a slip).
    """
    geo = _Geometry(part)
    g = float(gravity)
    k, theta, omega, px = (
        k.copy(),
        theta.astype(float).copy(),
        omega.astype(float).copy(),
        pivot_x.astype(float).copy(),
    )
    batch = len(k)
    mus = np.broadcast_to(np.asarray(mu, dtype=float), (batch,))
    out = Settled(
        np.full(batch, -1),
        np.full(batch, np.nan),
        np.full(batch, np.nan),
        np.zeros(batch, dtype=int),
        np.zeros(batch, dtype=bool),
        np.zeros(batch, dtype=bool),
        px.copy(),
        px.copy(),
    )
    active = np.arange(batch)
    for _ in range(MAX_IMPACTS):
        if active.size == 0:
            return out
        th, om = theta[active], omega[active]
        kk, pp, direction = _pivot(geo, k[active], th, om, px[active])
        _, lo, hi = _interval(geo, kk, th)
        h0 = _height(geo, kk, th)
        old = np.where(direction > 0, hi, lo)
        direction, target, h_target, om_end = _swing(geo, g, kk, th, om, direction, lo, hi)
        energy = 0.5 * geo.inertia[kk] * om * om - g * h0
        top = np.minimum(
            np.maximum(_path_peak(geo, kk, th, old), _path_peak(geo, kk, th, target)), energy / -g
        )
        out.lift_off[active] |= lift_off_in_swing(geo.rho, g, energy, np.minimum(h0, h_target), top)
        j, e, cm_x, om_new, p_new = _strike(geo, kk, direction, target, h_target, om_end, pp)
        out.slip[active] |= _strike_slip(geo, kk, j, target, h_target, om_end, om_new, mus[active])
        for x in (pp, p_new):
            out.contact_min[active] = np.minimum(out.contact_min[active], x)
            out.contact_max[active] = np.maximum(out.contact_max[active], x)
        done = _settled(geo, g, kk, j, e, direction, target, h_target, lo, hi, om_new)
        idx = active[done]
        out.edge[idx], out.x[idx], out.theta[idx] = e[done], cm_x[done], target[done]
        out.impacts[active] += 1
        go = ~done
        k[active[go]], theta[active[go]] = j[go], target[go]
        omega[active[go]], px[active[go]] = om_new[go], p_new[go]
        active = active[go]
    raise SolverError(
        f"{active.size} part(s) still rolling after {MAX_IMPACTS} sticking impacts; not settled"
    )
