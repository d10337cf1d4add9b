"""Rolling about the impact vertex under gravity, the next sticking impact, and settling (section III-B)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.impact import sticking_impact

TWO_PI = 2 * math.pi
MAX_IMPACTS = 20000  # sticking impacts shed a fixed fraction of energy each, so settling takes far fewer


@dataclass
class Settled:
    """Where each part of a batch came to rest: edge, centre-of-mass x, absolute angle, impacts taken."""

    edge: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    impacts: np.ndarray


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


def settle(
    part: ArmPart, gravity: float, k: np.ndarray, theta: np.ndarray, omega: np.ndarray, pivot_x: np.ndarray
) -> Settled:
    """Roll each part about its pivot vertex until it settles on an edge it can no longer escape.

    Rolling about vertex k conserves energy E = I_k omega^2 / 2 - g c_y (per unit mass, I_k = rho^2 + |q_k|^2).
    The part reaches the end of k's angular interval in its direction of motion if E exceeds the highest
    potential on the way, else it swings back to the other end. At an end the next vertex strikes: a sticking
    impact, eqs. (7)-(9). If the struck vertex's velocity would push the other vertex of the now flat edge into
    the arm, both vertices stick (omega = 0). A part on a flat stable edge whose kinetic energy is below the
    barriers over both its vertices has settled (every later impact only removes energy).
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
    out = Settled(
        np.full(batch, -1), np.full(batch, np.nan), np.full(batch, np.nan), np.zeros(batch, dtype=int)
    )
    active = np.arange(batch)
    for _ in range(MAX_IMPACTS):
        if active.size == 0:
            return out
        kk, th, om, pp = k[active], theta[active], omega[active], px[active]
        off = _offset(geo, kk, th)
        ext = geo.ext[kk]
        lo = th - off
        hi = lo + ext
        # Direction: of the motion, or of the gravity torque g c_x / I from rest.
        cx = _cm_dx(geo, kk, th)
        direction = np.where(om != 0, np.sign(om), np.where(cx > 0, -1.0, 1.0))
        # From rest on a flat edge, rotating into the arm means the other vertex is the pivot.
        at_lo, at_hi = off <= 1e-12, off >= ext - 1e-12
        swap_up = (om == 0) & at_lo & (direction < 0)
        swap_down = (om == 0) & at_hi & (direction > 0)
        if swap_up.any() or swap_down.any():
            cm_x = pp + cx
            kk = np.where(swap_up, (kk + 1) % geo.n, np.where(swap_down, (kk - 1) % geo.n, kk))
            pp = np.where(swap_up | swap_down, cm_x - _cm_dx(geo, kk, th), pp)
            off = _offset(geo, kk, th)
            ext = geo.ext[kk]
            lo = th - off
            hi = lo + ext
        inertia = geo.inertia[kk]
        kinetic = 0.5 * inertia * om * om
        h0 = _height(geo, kk, th)
        target = np.where(direction > 0, hi, lo)
        peak = _path_peak(geo, kk, th, target)
        h_target = _height(geo, kk, target)
        downhill = (peak <= h0) & (h_target <= h0)
        reach = downhill | (kinetic > -g * (peak - h0))
        direction = np.where(reach, direction, -direction)
        target = np.where(reach, target, np.where(direction > 0, hi, lo))
        h_target = _height(geo, kk, target)
        speed2 = np.maximum(2.0 * (kinetic + g * (h_target - h0)) / inertia, 0.0)
        om_end = direction * np.sqrt(speed2)
        # Strike of the neighbouring vertex j on edge e, now flat.
        j = np.where(direction > 0, (kk - 1) % geo.n, (kk + 1) % geo.n)
        e = np.where(direction > 0, (kk - 1) % geo.n, kk)
        c, s = np.cos(target), np.sin(target)
        cx_t = -(c * geo.qx[kk] - s * geo.qy[kk])
        cy_t = h_target
        cm_x = pp + cx_t
        vx, vy = -om_end * cy_t, om_end * cx_t
        rx = c * geo.qx[j] - s * geo.qy[j]
        ry = s * geo.qx[j] + c * geo.qy[j]
        _, _, om_new = sticking_impact(rx, ry, vx, vy, om_end, geo.rho)
        into_arm = np.where(direction > 0, om_new < 0, om_new > 0)
        om_new = np.where(into_arm, 0.0, om_new)
        p_new = cm_x + rx
        # Settling: a flat stable edge with too little energy to tip over either of its vertices.
        kin_new = 0.5 * geo.inertia[j] * om_new * om_new
        off_j = _offset(geo, j, target)
        far_j = np.where(direction > 0, target - off_j + geo.ext[j], target - off_j)
        barrier_j = -g * (_path_peak(geo, j, target, far_j) - _height(geo, j, target))
        far_k = np.where(direction > 0, lo, hi)
        barrier_k = -g * (_path_peak(geo, kk, target, far_k) - h_target)
        done = geo.stable[e] & (kin_new < np.minimum(barrier_j, barrier_k))
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
