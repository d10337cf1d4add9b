"""The `contact` fidelity: the paper's throw map plus lift-off and Coulomb impacts, event-driven and exact.

Between the paper's model (``feeder_planner.throwing.throw_map``: impulsive release, flight, a sticking
catch and rolling without slip, section III) and pymunk (``dynamic``: finite restitution and time steps)
this model drops exactly two of the paper's assumptions and keeps everything else:

* **Lift-off.** Rolling about a pivot vertex needs a non-negative normal force; where the force reaches
  zero (``lift_off_in_swing`` gives the quadratic in c_y) the part leaves the pivot and flies again,
  eqs. (5), (6) from the state at that instant, to the next vertex contact.
* **Coulomb impacts.** A catch or strike sticks (eqs. 7-9) only when the sticking impulse lies inside the
  friction cone |J_t| <= mu J_n; otherwise it is a sliding impact: perfectly plastic in the normal
  direction (the vertex's normal velocity becomes zero) with the tangential impulse on the cone's edge,
  J_t = -sigma mu J_n against the slip direction sigma (Coulomb's law for impulses with slip in one
  direction throughout, Stronge, *Impact Mechanics*, 2000, ch. 3.3; Brach, *Mechanical Impact Dynamics*,
  1991, ch. 3). The vertex then slides on the arm (``_slide``: one-contact Coulomb sliding, integrated
  with event location) until it sticks and rolls, lifts off, or the next vertex strikes.

Where neither event happens the trajectory is the paper's, computed with the paper's own rolling steps
(the same arithmetic), so both models agree to the last bit there. Event times and angles come from
closed forms (lift-off: the quadratic N(c_y) = 0 and arcsin) or bracketed root finding (flight: the
certified earliest impact of ``flight``; sliding: the ODE solver's event location), with the tolerances
of ``tolerances`` (section "contact fidelity").

Not modelled (kept from the paper): the impulsive release, friction during rolling between impacts
(only impacts are checked against the cone), an arm of unbounded length (``off_arm`` is reported as in
the paper model). A sliding edge lying flat decelerates at mu |g| to rest.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from feeder_planner.errors import SolverError
from feeder_planner.throwing.flight import (
    _first_crossings,
    _flight_end,
    _piece_minima,
    _Pieces,
    _pieces,
    earliest_impact,
    flight_state,
    rest_pose,
)
from feeder_planner.throwing.geometry import ArmPart
from feeder_planner.throwing.impact import sticking_impact
from feeder_planner.throwing.rolling import (
    _cm_dx,
    _Geometry,
    _height,
    _interval,
    _pivot,
    _settled,
    _strike,
    _strike_slip,
    _swing,
    outside_cone,
)
from feeder_planner.throwing.throw_map import ThrowParams, ThrowResult, check_start, throw_kind, whole_turns
from feeder_sim.throwing.tolerances import (
    CONTACT_ATOL,
    CONTACT_RTOL,
    LEVEL_SLACK,
    LIFT_GUARD,
    MAX_CONTACT_EVENTS,
    SLIDE_TIME_LIMIT,
)

__all__ = ["ContactEvent", "ContactThrow", "contact_trace", "contact_throw", "sliding_impulse"]

TWO_PI = 2 * math.pi


@dataclass(frozen=True)
class ContactEvent:
    """One event of a contact throw: what happened, at which vertex, and the energy right after it.

    ``kind`` is "catch" or "strike" (a sticking impact), "slide" (a sliding impact), "lift_off", "stick"
    (a slide ended in rolling), "flat" (an edge came down sliding) or "rest". ``energy`` is the
    mechanical energy per unit mass (kinetic + potential above the arm, m^2/s^2) and ``state`` the body
    state (x, y, theta, xdot, ydot, thetadot) right after it. For a sliding impact ``impulse`` is
    (J_t, J_n) per unit mass and ``slip`` the vertex's tangential velocity before it.
    """

    kind: str
    vertex: int
    energy: float
    state: tuple[float, float, float, float, float, float]
    impulse: tuple[float, float] = (0.0, 0.0)
    slip: float = 0.0


@dataclass(frozen=True)
class ContactThrow:
    """A contact-fidelity throw: the result (as the paper model's, fidelity "contact") and its events.

    ``result.lift_off`` and ``result.slip`` say that the model met (and handled) a lift-off or a sliding
    impact; ``hops`` and ``slides`` count them.
    """

    result: ThrowResult
    events: tuple[ContactEvent, ...] = field(default=())

    @property
    def hops(self) -> int:
        """Number of lift-offs (the part left its pivot and flew again)."""
        return sum(e.kind == "lift_off" for e in self.events)

    @property
    def slides(self) -> int:
        """Number of sliding impacts."""
        return sum(e.kind == "slide" for e in self.events)


@dataclass
class _State:
    """Rigid-body state in the arm frame: centre of mass (x, y), angle theta, and their rates."""

    x: float
    y: float
    theta: float
    vx: float
    vy: float
    omega: float


def _arr(value: float | int) -> np.ndarray:
    """Return a one-element array (the paper's vectorised steps run on batches of one here)."""
    return np.array([value])


class _Run:
    """One throw in progress: geometry, parameters, the event log and the contact extent."""

    def __init__(self, part: ArmPart, params: ThrowParams) -> None:
        self.part, self.geo = part, _Geometry(part)
        self.h, self.g, self.mu = params.offset, float(params.gravity), float(params.mu)
        self.events: list[ContactEvent] = []
        self.impacts = 0
        self.lo_x, self.hi_x = math.inf, -math.inf

    def r(self, k: int, theta: float) -> tuple[float, float]:
        """Return the vector from the centre of mass to hull vertex k at angle theta."""
        qx, qy = float(self.geo.qx[k]), float(self.geo.qy[k])
        c, s = math.cos(theta), math.sin(theta)
        return c * qx - s * qy, s * qx + c * qy

    def energy(self, st: _State) -> float:
        """Return the mechanical energy per unit mass (potential measured from the arm surface)."""
        rho2 = self.geo.rho**2
        return 0.5 * (st.vx**2 + st.vy**2 + rho2 * st.omega**2) - self.g * (st.y - self.h)

    def log(self, kind: str, vertex: int, st: _State, **extra: tuple[float, float] | float) -> None:
        """Append an event, with the energy of ``st``; bound the number of events."""
        state = (st.x, st.y, st.theta, st.vx, st.vy, st.omega)
        self.events.append(ContactEvent(kind, vertex, self.energy(st), state, **extra))  # type: ignore[arg-type]
        if len(self.events) > MAX_CONTACT_EVENTS:
            raise SolverError(f"contact throw not settled after {MAX_CONTACT_EVENTS} events")

    def touch(self, x: float) -> None:
        """Widen the range of x the part's contacts with the arm have covered."""
        self.lo_x, self.hi_x = min(self.lo_x, x), max(self.hi_x, x)

    def pivot_state(self, k: int, theta: float, omega: float, pivot_x: float) -> _State:
        """Return the body state of a part rotating at ``omega`` about vertex k resting at ``pivot_x``."""
        cx = float(_cm_dx(self.geo, _arr(k), _arr(theta))[0])
        cy = float(_height(self.geo, _arr(k), _arr(theta))[0])
        return _State(pivot_x + cx, self.h + cy, theta, -omega * cy, omega * cx, omega)


def sliding_impulse(
    rx: float, ry: float, vx: float, vy: float, omega: float, rho: float, mu: float
) -> tuple[float, float, float, bool]:
    """Return (J_t, J_n, d omega, stuck) of a perfectly plastic impact with Coulomb friction at a vertex.

    Stronge's incremental law (Stronge, *Impact Mechanics*, 2000, ch. 3.3-3.4; Brach 1991, ch. 3): the
    contact velocity is linear in the impulse, dv = K dP with K_tt = 1 + ry^2/rho^2, K_nn = 1 + rx^2/rho^2,
    K_tn = K_nt = -rx ry / rho^2 (per unit mass, (rx, ry) from the centre of mass to the vertex). While
    the vertex slips in direction sigma, dP_t = -sigma mu dP_n; if the slip stops before the normal
    velocity is zero (the end of compression, restitution 0), the vertex sticks when the ratio that holds
    it, |K_tn / K_tt|, is within mu, else it slips back the other way. ``stuck``: the vertex ends at rest.
    A normal velocity that would not rise with the normal impulse (Painleve's inconsistency of rigid-body
    friction) is refused.
    """
    rho2 = rho * rho
    k_tt, k_nn, k_tn = 1.0 + ry * ry / rho2, 1.0 + rx * rx / rho2, -rx * ry / rho2
    v_t, v_n = vx - omega * ry, vy + omega * rx
    hold = -k_tn / k_tt  # dP_t / dP_n that keeps v_t = 0
    p_t = p_n = 0.0
    sigma = math.copysign(1.0, v_t) if v_t != 0 else -math.copysign(1.0, hold)
    stuck = v_t == 0 and abs(hold) <= mu
    for _ in range(3):  # slip, possibly stop, then stick or slip back: at most three phases
        ratio = hold if stuck else -sigma * mu
        rate_t, rate_n = (0.0 if stuck else k_tt * ratio + k_tn), k_tn * ratio + k_nn
        if rate_n <= 0:
            raise SolverError("impact inconsistent (Painleve): mu too large for this contact geometry")
        to_end = -v_n / rate_n
        to_stop = -v_t / rate_t if rate_t * v_t < 0 else math.inf
        step = min(to_end, to_stop)
        p_n, p_t = p_n + step, p_t + ratio * step
        v_n, v_t = v_n + rate_n * step, (0.0 if step == to_stop else v_t + rate_t * step)
        if step == to_end:
            break
        stuck = abs(hold) <= mu
        sigma = -sigma
    return p_t, p_n, (rx * p_n - ry * p_t) / rho2, stuck


def _level_travel(s: float, gamma: float, theta: float, direction: float, span: float, level: float) -> float:
    """Return the first rotation tau in (0, span] from ``theta`` in ``direction`` where c_y = ``level``.

    c_y(theta) = -s sin(theta + gamma) (the centre of mass's height above the pivot); inf if none.
    """
    ratio = -level / s
    if abs(ratio) > 1:
        return math.inf
    base = math.asin(ratio)
    best = math.inf
    for phase in (base, math.pi - base):
        tau = math.fmod(direction * (phase - gamma - theta), TWO_PI)
        tau = tau + TWO_PI if tau < 0 else tau
        if 0 < tau <= span:
            best = min(best, tau)
    return best


def _lift_off_angle(
    run: _Run, k: int, theta: float, omega: float, direction0: float, direction: float, target: float
) -> tuple[float, float] | None:
    """Return (angle, omega) where the pivot's normal force first reaches zero on this swing, or None.

    N = (-g rho^2 - 2 E c_y - 3 g c_y^2) / I (``rolling.lift_off_in_swing``) is negative exactly for c_y
    strictly between the roots c1 < c2 of the quadratic; the swing enters that band where c_y crosses c1
    or c2 (closed form, ``_level_travel``). A swing that turns back first retraces heights already
    checked, then goes past its start toward the other end of the interval.
    """
    geo, g = run.geo, run.g
    inertia = float(geo.inertia[k])
    s, gamma = math.sqrt(float(geo.s2[k])), float(geo.gamma[k])
    c0 = -s * math.sin(theta + gamma)
    energy = 0.5 * inertia * omega * omega - g * c0
    disc = energy * energy - 3.0 * g * g * geo.rho**2
    if disc <= 0:
        return None
    c1, c2 = (energy - math.sqrt(disc)) / (-3.0 * g), (energy + math.sqrt(disc)) / (-3.0 * g)

    def band_state(angle: float, sign: float) -> tuple[float, float]:
        c = -s * math.sin(angle + gamma)
        return angle, sign * math.sqrt(max(2.0 * (energy + g * c) / inertia, 0.0))

    if c1 < c0 < c2:
        return theta, omega
    legs = []
    if direction == direction0:
        legs.append((direction0, abs(target - theta)))
    else:
        turn = _level_travel(s, gamma, theta, direction0, TWO_PI, energy / -g)
        legs.append((direction0, turn))
        legs.append((direction, abs(target - theta)))
    for leg_direction, span in legs:
        tau = min(_level_travel(s, gamma, theta, leg_direction, span, c) for c in (c1, c2))
        if math.isfinite(tau):
            return band_state(theta + leg_direction * tau, leg_direction)
    return None


def _flight(run: _Run, st: _State, lifted: int) -> tuple[float, int]:
    """Return (t, k): the first time a hull vertex other than one just lifting off touches the arm.

    Vertex k's height above the arm is f_k(t) = (y - h) + vy t + g t^2/2 + s_k sin(omega t + c_k),
    the form ``flight.earliest_impact`` certifies (convex/concave pieces, bisection to 2^-60 of the
    flight); a negative spin is written as a positive one (sin(-w t + c) = sin(w t + pi - c)). The vertex
    that has just left the pivot starts with f = f' = 0, so its pieces begin LIFT_GUARD of a radian of
    rotation later (or the same fraction of the free-fall time of the part's radius without spin).
    """
    g = run.g
    q = run.part.hull
    s = np.hypot(q[:, 0], q[:, 1])[None, :]
    c = (np.arctan2(q[:, 1], q[:, 0]) + st.theta)[None, :]
    w = st.omega
    if w < 0:
        c, w = math.pi - c, -w
    d, b = np.array([[st.y - run.h]]), np.array([[st.vy]])
    t_end = _flight_end(d, b, g)
    pieces = _pieces(d, b, s, c, w, g, t_end)
    scale = math.sqrt(run.part.radius / -g)
    guard = LIFT_GUARD / w if w > LIFT_GUARD / scale else LIFT_GUARD * scale
    lo = np.where(pieces.vertex == lifted, np.maximum(pieces.lo, guard), pieces.lo)
    keep = pieces.hi > lo
    pieces = _Pieces(
        pieces.w[keep],
        pieces.throw[keep],
        pieces.vertex[keep],
        lo[keep],
        pieces.hi[keep],
        pieces.d[keep],
        pieces.b[keep],
        pieces.s[keep],
        pieces.c[keep],
    )
    t_hit, owner = _first_crossings(pieces, _piece_minima(pieces, g), g, 1)
    if owner[0] < 0:
        raise SolverError("flight after lift-off ended without an impact")
    return float(t_hit[0]), int(owner[0])


def _fly(run: _Run, st: _State, t: float) -> _State:
    """Return the free-flight state t after ``st`` (eq. 5 from a general state)."""
    return _State(
        st.x + st.vx * t,
        st.y + st.vy * t + 0.5 * run.g * t * t,
        st.theta + st.omega * t,
        st.vx,
        st.vy + run.g * t,
        st.omega,
    )


@dataclass
class _Rest:
    """Where the part came to rest: edge, centre-of-mass x, absolute angle."""

    edge: int
    x: float
    theta: float


@dataclass(frozen=True)
class _Next:
    """The next phase of a throw (a trampoline: phases chain without growing the call stack)."""

    step: Callable[[], _Rest | _Next]  # the phase with its arguments bound (functools.partial)


_Outcome = _Rest | _Next


def _impact(run: _Run, st: _State, k: int, kind: str) -> _Outcome:
    """Resolve an impact of vertex k (the only vertex on the arm): stick and roll, or slide."""
    run.impacts += 1
    rx, ry = run.r(k, st.theta)
    xp, yp, om = sticking_impact(_arr(rx), _arr(ry), _arr(st.vx), _arr(st.vy), _arr(st.omega), run.geo.rho)
    run.touch(st.x + rx)
    if not bool(outside_cone(xp - st.vx, yp - st.vy, run.mu)[0]):
        after = _State(st.x, st.y, st.theta, float(xp[0]), float(yp[0]), float(om[0]))
        run.log(kind, k, after)
        return _Next(partial(_roll, run, k, st.theta, float(om[0]), st.x + rx))
    j_t, j_n, d_omega, stuck = sliding_impulse(rx, ry, st.vx, st.vy, st.omega, run.geo.rho, run.mu)
    slip = st.vx - st.omega * ry
    after = _State(st.x, st.y, st.theta, st.vx + j_t, st.vy + j_n, st.omega + d_omega)
    run.log("slide", k, after, impulse=(j_t, j_n), slip=slip)
    if stuck:
        return _Next(partial(_roll, run, k, st.theta, after.omega, st.x + rx))
    return _Next(partial(_slide, run, after, k))


def _roll(run: _Run, k: int, theta: float, omega: float, pivot_x: float) -> _Outcome:
    """Roll about vertex k as ``rolling.settle`` does (same steps), leaving it at a lift-off or a slip.

    One swing per round: its end and the struck vertex come from the paper's own functions, so that a
    throw without events is the paper's to the last bit.
    """
    geo, g = run.geo, run.g
    k_a, th, om, px = _arr(k), _arr(theta), _arr(omega), _arr(pivot_x)
    while True:
        kk, pp, direction0 = _pivot(geo, k_a, th, om, px)
        _, lo, hi = _interval(geo, kk, th)
        direction, target, h_target, om_end = _swing(geo, g, kk, th, om, direction0, lo, hi)
        run.touch(float(pp[0]))
        pivot = int(kk[0])
        lift = _lift_off_angle(
            run,
            pivot,
            float(th[0]),
            float(om[0]),
            float(direction0[0]),
            float(direction[0]),
            float(target[0]),
        )
        if lift is not None:
            st = run.pivot_state(pivot, lift[0], lift[1], float(pp[0]))
            run.log("lift_off", pivot, st)
            t, hit = _flight(run, st, pivot)
            return _Next(partial(_impact, run, _fly(run, st, t), hit, "catch"))
        j, e, cm_x, om_new, p_new = _strike(geo, kk, direction, target, h_target, om_end, pp)
        if bool(_strike_slip(geo, kk, j, target, h_target, om_end, om_new, run.mu)[0]):
            # The sticking strike would need more friction than mu: a sliding impact at j instead.
            before = run.pivot_state(pivot, float(target[0]), float(om_end[0]), float(pp[0]))
            run.touch(float(p_new[0]))
            return _Next(partial(_strike_sliding, run, before, int(j[0]), int(e[0]), pivot))
        run.impacts += 1
        run.touch(float(p_new[0]))
        after = run.pivot_state(int(j[0]), float(target[0]), float(om_new[0]), float(p_new[0]))
        run.log("strike", int(j[0]), after)
        if bool(_settled(geo, g, kk, j, e, direction, target, h_target, lo, hi, om_new)[0]):
            return _Rest(int(e[0]), float(cm_x[0]), float(target[0]))
        k_a, th, om, px = j, target, om_new, p_new


def _strike_sliding(run: _Run, st: _State, j: int, e: int, old: int) -> _Outcome:
    """Resolve a sliding strike of vertex j as the old pivot leaves the arm (edge e comes down flat).

    If the impact's spin would press the old pivot into the arm, edge e lies flat: both vertices take
    the normal impulse (no spin, no normal velocity) and friction mu |J_n| slows the slide, which ends at
    rest after v^2 / (2 mu |g|) more.
    """
    run.impacts += 1
    rx, ry = run.r(j, st.theta)
    j_t, j_n, d_omega, stuck = sliding_impulse(rx, ry, st.vx, st.vy, st.omega, run.geo.rho, run.mu)
    slip = st.vx - st.omega * ry
    after = _State(st.x, st.y, st.theta, st.vx + j_t, st.vy + j_n, st.omega + d_omega)
    run.log("slide", j, after, impulse=(j_t, j_n), slip=slip)
    ox, _ = run.r(old, st.theta)
    if after.omega * (ox - rx) < 0 or after.omega == 0:  # the old pivot would move into the arm
        return _Next(partial(_flat, run, st, j, e))
    if stuck:
        return _Next(partial(_roll, run, j, st.theta, after.omega, st.x + rx))
    return _Next(partial(_slide, run, after, j))


def _flat(run: _Run, st: _State, j: int, e: int) -> _Outcome:
    """Edge e lands flat: plastic in the normal direction, Coulomb-limited in the tangential one."""
    normal = -st.vy  # the normal impulse per unit mass that stops the fall (both vertices together)
    vx = st.vx - math.copysign(min(abs(st.vx), run.mu * max(normal, 0.0)), st.vx)
    x = st.x + vx * abs(vx) / (2.0 * run.mu * -run.g)
    rest = _State(x, st.y, st.theta, 0.0, 0.0, 0.0)
    rx, _ = run.r(j, st.theta)
    run.touch(x + rx)
    run.log("flat", j, _State(st.x, st.y, st.theta, vx, 0.0, 0.0), impulse=(vx - st.vx, normal), slip=st.vx)
    if bool(run.part.stable[e]):
        run.log("rest", j, rest)
        return _Rest(e, x, st.theta)
    return _Next(partial(_roll, run, j, st.theta, 0.0, x + rx))


def _slide(run: _Run, st: _State, k: int, sigma: float = 0.0) -> _Outcome:
    """Slide on vertex k (one contact, kinetic Coulomb friction) until it sticks, lifts off or strikes.

    Per unit mass, with r the vertex from the centre of mass, sigma the slip direction and
    D = 1 + rx (rx + sigma mu ry) / rho^2: N = (ry omega^2 - g) / D, a_x = -sigma mu N,
    alpha = N (rx + sigma mu ry) / rho^2, and y follows from the vertex staying on the arm. Integrated
    (DOP853, CONTACT_RTOL / CONTACT_ATOL) with the events located by the solver's root finding.
    ``sigma`` (+-1) is the slip direction when the slip starts from rest (0: from the slip velocity).
    """
    n = run.part.n
    if sigma == 0.0:
        sigma = 1.0 if st.vx - st.omega * run.r(k, st.theta)[1] > 0 else -1.0
    scale = math.sqrt(run.part.radius / -run.g)
    neighbours = ((k - 1) % n, (k + 1) % n)
    rates, events = _slide_equations(run, st, k, sigma, neighbours)
    lift, painleve = events[0], events[4]  # checked at the start too: the solver only sees crossings
    z0 = np.array([st.x, st.theta, st.vx, st.omega])
    if painleve(0.0, z0) <= 0:
        raise SolverError("sliding contact inconsistent (Painleve): mu too large for this contact geometry")
    if lift(0.0, z0) < 0:  # the slide would need a pulling normal force: the part leaves at once
        run.log("lift_off", k, st)
        t, hit = _flight(run, st, k)
        return _Next(partial(_impact, run, _fly(run, st, t), hit, "catch"))
    from scipy.integrate import solve_ivp  # only the dynamic fidelity slides: the arm's start skips scipy

    sol = solve_ivp(
        rates,
        (0.0, SLIDE_TIME_LIMIT * scale),
        z0,
        method="DOP853",
        events=events,
        rtol=CONTACT_RTOL,
        atol=CONTACT_ATOL * run.part.radius / scale,
    )
    return _slide_end(run, sol, k, sigma, neighbours)


def _slide_equations(
    run: _Run, st: _State, k: int, sigma: float, neighbours: tuple[int, int]
) -> tuple[Callable[[float, np.ndarray], np.ndarray], list[Callable[[float, np.ndarray], float]]]:
    """Return the slide's rates and its events: lift-off, stick, a strike of each neighbour, Painleve.

    Per unit mass, with D = 1 + rx (rx + sigma mu ry) / rho^2: N = (ry omega^2 - g) / D, a_x = -sigma mu N,
    alpha = N (rx + sigma mu ry) / rho^2 (the state is x, theta, vx, omega). The events, all terminal, in
    this order: N reaching zero (lift-off), the slip velocity reaching zero (stick), each neighbour
    coming down to the arm (strike), D reaching zero (Painleve's inconsistency).
    """
    g, mu, rho2 = run.g, run.mu, run.geo.rho**2

    def rates(_t: float, z: np.ndarray) -> np.ndarray:
        theta, omega = z[1], z[3]
        rx, ry = run.r(k, theta)
        normal = (ry * omega * omega - g) / (1.0 + rx * (rx + sigma * mu * ry) / rho2)
        return np.array([z[2], omega, -sigma * mu * normal, normal * (rx + sigma * mu * ry) / rho2])

    def lift(_t: float, z: np.ndarray) -> float:
        rx, ry = run.r(k, z[1])
        return (ry * z[3] ** 2 - g) / (1.0 + rx * (rx + sigma * mu * ry) / rho2)

    def stuck(_t: float, z: np.ndarray) -> float:
        return z[2] - z[3] * run.r(k, z[1])[1]

    def strike(m: int) -> Callable[[float, np.ndarray], float]:
        # A neighbour still on the arm (the other end of an edge that has just come down) starts at a
        # height of zero up to rounding, whose sign the solver would misread: measure it from its start.
        start = run.r(m, st.theta)[1] - run.r(k, st.theta)[1]
        level = start if abs(start) <= LEVEL_SLACK * run.part.radius else 0.0

        def height(_t: float, z: np.ndarray) -> float:
            return run.r(m, z[1])[1] - run.r(k, z[1])[1] - level

        height.terminal, height.direction = True, -1  # type: ignore[attr-defined]
        return height

    def painleve(_t: float, z: np.ndarray) -> float:
        rx, ry = run.r(k, z[1])
        return 1.0 + rx * (rx + sigma * mu * ry) / rho2

    lift.terminal, lift.direction = True, -1  # type: ignore[attr-defined]
    # Only a slip running down to zero ends it (a slip starting from rest begins at zero).
    stuck.terminal, stuck.direction = True, -sigma  # type: ignore[attr-defined]
    painleve.terminal, painleve.direction = True, -1  # type: ignore[attr-defined]
    return rates, [lift, stuck, strike(neighbours[0]), strike(neighbours[1]), painleve]


def _slide_end(run: _Run, sol: Any, k: int, sigma: float, neighbours: tuple[int, int]) -> _Outcome:
    """Take the slide to its first event (``sol``: the solver's result): the phase that follows it.

    Lift-off flies, a stop rolls or slides back (``_stick``), a neighbour's strike is an impact on the
    edge it closes; no event within the time limit, or Painleve's inconsistency, raises SolverError.
    """
    fired = [i for i, times in enumerate(sol.t_events) if len(times)]
    if not fired:
        raise SolverError("sliding contact did not end within its time limit")
    which = min(fired, key=lambda i: sol.t_events[i][0])
    if which == 4:
        raise SolverError("sliding contact became inconsistent (Painleve): mu too large for this geometry")
    x, theta, vx, omega = (float(v) for v in sol.y_events[which][0])
    rx, ry = run.r(k, theta)
    now = _State(x, run.h - ry, theta, vx, -omega * rx, omega)
    run.touch(x + rx)
    if which == 0:
        run.log("lift_off", k, now)
        t, hit = _flight(run, now, k)
        return _Next(partial(_impact, run, _fly(run, now, t), hit, "catch"))
    if which == 1:
        return _Next(partial(_stick, run, now, k, sigma))
    m = neighbours[which - 2]
    e = k if m == (k + 1) % run.part.n else m  # the edge between k and m (edge i joins vertices i, i + 1)
    return _Next(partial(_strike_general, run, now, m, e, k))


def _stick(run: _Run, st: _State, k: int, sigma: float) -> _Outcome:
    """Roll about k from where the slip stopped if friction holds the rolling, else slide the other way."""
    geo, g = run.geo, run.g
    rx, ry = run.r(k, st.theta)
    inertia = float(geo.inertia[k])
    cx, cy = -rx, -ry
    alpha = g * cx / inertia
    ax, ay = -alpha * cy - st.omega**2 * cx, alpha * cx - st.omega**2 * cy
    normal = ay - g
    if normal >= 0 and abs(ax) <= run.mu * normal:
        run.log("stick", k, st)
        return _Next(partial(_roll, run, k, st.theta, st.omega, st.x + rx))
    if normal < 0:
        run.log("lift_off", k, st)
        t, hit = _flight(run, st, k)
        return _Next(partial(_impact, run, _fly(run, st, t), hit, "catch"))
    # Static friction cannot hold: slip starts against the force it would have needed.
    run.log("slip_start", k, st)
    return _Next(partial(_slide, run, st, k, -math.copysign(1.0, ax)))


def _strike_general(run: _Run, st: _State, j: int, e: int, old: int) -> _Outcome:
    """Vertex j strikes while the part slides on ``old``: a sticking or a sliding impact at j.

    A vertex reaching the arm without approaching it (the other end of an edge lying flat, found at the
    slide's start) is no impact: the edge rests flat on both vertices (``_flat``).
    """
    rx, ry = run.r(j, st.theta)
    if st.vy + st.omega * rx >= -LEVEL_SLACK * math.sqrt(run.part.radius * -run.g):
        return _Next(partial(_flat, run, st, j, e))
    xp, yp, om = sticking_impact(_arr(rx), _arr(ry), _arr(st.vx), _arr(st.vy), _arr(st.omega), run.geo.rho)
    if bool(outside_cone(xp - st.vx, yp - st.vy, run.mu)[0]):
        return _Next(partial(_strike_sliding, run, st, j, e, old))
    run.impacts += 1
    run.touch(st.x + rx)
    omega = float(om[0])
    ox, _ = run.r(old, st.theta)
    if omega * (ox - rx) < 0:  # the old pivot would be pressed into the arm: edge e rests flat
        omega = 0.0
    after = _State(st.x, st.y, st.theta, ry * omega, -rx * omega, omega)
    run.log("strike", j, after)
    if omega == 0.0 and bool(run.part.stable[e]):
        run.log("rest", j, after)
        return _Rest(e, st.x, st.theta)
    return _Next(partial(_roll, run, j, st.theta, omega, st.x + rx))


def contact_trace(part: ArmPart, edge: int, radius: float, params: ThrowParams) -> ContactThrow:
    """Throw once at the contact fidelity (domain checked as the paper model's) and keep the events.

    Release and flight as in eqs. (5), (6); the first impact and every later one resolved by the
    friction cone of ``params.mu`` (``_impact``); rolling as in section III-B with lift-off checked.
    """
    check_start(part, edge, radius, params)
    run = _Run(part, params)
    t, k = earliest_impact(part, np.array([edge]), np.array([radius]), 0.0, params.speed, params.gravity)
    x, y, theta, vx, vy, om = (
        float(v) for v in flight_state(part, edge, radius, params.offset, params.speed, params.gravity, t)[0]
    )
    step: _Outcome = _impact(run, _State(x, y, theta, vx, vy, om), int(k[0]), "catch")
    while isinstance(step, _Next):  # bounded: every phase logs an event, MAX_CONTACT_EVENTS in all
        step = step.step()
    rest = step
    theta0 = float(rest_pose(part, edge, radius, params.offset)[2])
    rotation = rest.theta - theta0
    left = rest.x + float(part.u_left[rest.edge])
    kinds = {e.kind for e in run.events}
    result = ThrowResult(
        edge=rest.edge,
        radius=rest.x,
        kind=throw_kind(edge, rest.edge, rotation),
        rotation=rotation,
        turns=int(whole_turns(rotation)),
        flight_time=float(t[0]),
        impacts=run.impacts,
        start_edge=edge,
        start_radius=radius,
        lift_off="lift_off" in kinds,
        slip="slide" in kinds or "flat" in kinds,
        off_arm=min(run.lo_x, left) < 0 or run.hi_x > params.arm_length,
        toe_stub=left <= 0,
        fidelity="contact",
    )
    return ContactThrow(result, tuple(run.events))


def contact_throw(part: ArmPart, edge: int, radius: float, params: ThrowParams) -> ThrowResult:
    """Return one contact-fidelity throw (``contact_trace`` without the event log)."""
    return contact_trace(part, edge, radius, params).result
