"""The ideal model's integrator: Heun with error control and a stability limit, and no work at rest.

ROS-free; the scene (``scene.py``) calls ``IdealStepper.advance`` once per body and step of ``dt``.

**Motion law.** The quasi-static law v = F / (damping A), omega = M / (damping J) with F, M the field's
resultant force and torque (eqs. 1-2), which are minus the gradient of the lifted potential U (section 2:
the partial derivatives of U in x, y, theta are the opposite of force and torque). So the rate is a
gradient flow q' = -D^-1 grad U with D = diag(damping A, damping A, damping J): its Jacobian
-D^-1 Hess U is similar to the symmetric -D^-1/2 Hess U D^-1/2, every mode decays or grows along a real
eigenvalue, and at a stable equilibrium (a strict local minimum of U, section 2) all of them decay.

**Error control.** Heun's method (explicit trapezoid) with the embedded Euler step: the two velocity
evaluations k1 (at the pose) and k2 (an Euler step h further) give the local error estimate
h/2 |k2 - k1| for free, measured in the pose scale (x, y in part radii, theta in radians). A step whose
estimate exceeds ``STEP_ERROR_TOLERANCE`` is taken again shorter; the next step grows or shrinks with
(tolerance / estimate)^(1/2) (the estimate is O(h^2)). The step never exceeds the ``dt`` it is called
with, the configured ``time_step``: that is the largest step, and a ``dt`` always ends exactly on time.

**Stability limit.** The same two evaluations measure lambda h on the stiffest mode the velocity has
(|k2 - k1| / |k1|, in units of the settled speeds). Heun multiplies a real mode by 1 - z + z^2/2,
z = lambda h: it decays for z < 2 and freezes at z = 2 exactly, where k2 = -k1 and a part stops off its
equilibrium with a small error estimate (near rest the velocity is small). A step whose ratio passes
``STIFF_STEP_RATIO`` is cut to aim at ``STABLE_STEP_TARGET``. A ``dt`` on which a full step would have
passed the limit (the ratio scaled to ``dt``) is a stiff step: the configured time_step is beyond the
model's margin there and the steps had to be limited below it (counted; FAULT_TIME_STEP).

**Rest.** A body is at rest, and advancing it is skipped, when its velocity is exactly zero (no field:
the step is a fixed point bit for bit) or when it reads as settled and the linearised distance to the
equilibrium it is approaching, |J^-1 k1| with J the Jacobian of the rate (finite differences, once per
settling), is at most ``REST_TRAVEL`` with every mode of J decaying. In the linear regime the rest of the
motion is exactly that Newton step, so skipping it leaves the part within ``REST_TRAVEL`` of where the
integration would have taken it. Whatever changes the motion (the field, faults, drag, a placement)
wakes the body: the stepper compares the field, faults and drag with those of the rest, and the pose
with the pose it rested at.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from feeder_sim.mems.tolerances import (
    MIN_STEP_FRACTION,
    REST_DIFFERENCE,
    REST_NEUTRAL,
    REST_TRAVEL,
    SETTLED_ANGULAR_SPEED,
    SETTLED_SPEED,
    STABLE_STEP_TARGET,
    STEP_ERROR_TOLERANCE,
    STEP_GROWTH,
    STEP_SAFETY,
    STEP_SHRINK,
    STIFF_STEP_RATIO,
)

__all__ = ["SETTLED_SCALE", "Rate", "BodyState", "IdealStepper"]

# Velocities in units of the settled speeds: one norm for (vx, vy, omega), and below 1 a part is at rest.
SETTLED_SCALE = np.array([SETTLED_SPEED, SETTLED_SPEED, SETTLED_ANGULAR_SPEED])
_SETTLED = (SETTLED_SPEED, SETTLED_SPEED, SETTLED_ANGULAR_SPEED)

# The quasi-static velocity and wrench of one body at a pose: (k, wrench).
Rate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass
class BodyState:
    """What the stepper keeps of one body between calls."""

    step: float = 0.0  # the next step to try (s); 0: none yet, start at dt
    # The rate at ``rate_pose`` under ``conditions`` (reused by the next call when nothing changed).
    rate: np.ndarray | None = None
    wrench: np.ndarray | None = None
    # The pose and the rate as floats: the next call compares and steps in floats.
    rate_pose: list[float] | None = None
    rate_floats: list[float] | None = None
    # The inverse Jacobian of the rate near the settling pose, or None; ``unstable`` when J has a mode that
    # does not decay (a neutral or unstable equilibrium: no rest is certified there).
    inverse_jacobian: np.ndarray | None = None
    unstable: bool = False
    rest_pose: np.ndarray | None = None  # the pose the body rests at (skipped while it stays there)


class IdealStepper:
    """Adaptive Heun steps and rest detection for the ideal model's bodies (see the module docstring).

    Counters: ``evaluations`` (velocity evaluations, each one exact wrench), ``substeps`` (accepted Heun
    steps), ``rejected`` (steps taken again shorter), ``skipped`` (body-steps of ``dt`` not integrated at
    rest), ``stiff_steps`` (body-steps of ``dt`` a full step would have been unstable on), and
    ``peak_ratio``, the largest lambda h met since the scene's mark, scaled to the full ``dt``.
    """

    def __init__(self) -> None:
        self.states: list[BodyState] = []
        self.conditions: tuple[object, ...] = ()
        self.evaluations = 0
        self.substeps = 0
        self.rejected = 0
        self.skipped = 0
        self.stiff_steps = 0
        self.peak_ratio = 0.0

    def wake(self) -> None:
        """Forget every rest and cached rate: the next call integrates every body afresh."""
        self.states = [BodyState(step=s.step) for s in self.states]

    def added(self, count: int) -> None:
        """Keep a fresh state for a body appended as the ``count``-th (the others' states stay)."""
        if len(self.states) == count - 1:
            self.states.append(BodyState())

    def removed(self, index: int, count: int) -> None:
        """Drop the state of the body that was at ``index`` of ``count + 1`` (the others' states stay)."""
        if len(self.states) == count + 1:
            self.states.pop(index)

    def prepare(self, count: int, conditions: tuple[object, ...]) -> None:
        """Start a call for ``count`` bodies under ``conditions`` (field, faults, drag); wake on a change.

        Conditions are compared by identity and value: a field or faults object is immutable, so the same
        object is the same motion law.
        """
        if len(self.states) != count:
            self.states = [BodyState() for _ in range(count)]
        elif not _same(conditions, self.conditions):
            self.wake()
        self.conditions = conditions

    def _rate(self, rate: Rate, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.evaluations += 1
        return rate(pose)

    def advance(
        self, index: int, pose: np.ndarray, dt: float, rate: Rate, scale: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Advance body ``index`` from ``pose`` by ``dt``; None when it rests (nothing to do).

        ``rate`` is the body's quasi-static velocity and wrench at a pose, ``scale`` its radius (m).
        Returns the new pose, the velocity at it and the wrench at it.
        """
        state = self.states[index]
        if state.rest_pose is not None:
            if _same_pose(pose, state.rest_pose):
                self.skipped += 1
                return None
            state.rest_pose = state.inverse_jacobian = None  # placed elsewhere: moves again
            state.unstable = False
        weights = (scale, scale, 1.0)
        # The step's arithmetic in floats, the same operations in the same order as on arrays: numpy's
        # per-call cost on three numbers was most of a Heun step's bookkeeping.
        x = pose.tolist()
        if state.rate is not None and state.rate_floats is not None and state.rate_pose == x:
            k1, wrench, v1 = state.rate, state.wrench, state.rate_floats
            assert wrench is not None
        else:
            k1, wrench = self._rate(rate, pose)
            v1 = k1.tolist()
        remaining = dt
        h = min(state.step or dt, dt)
        stiff = False
        while remaining > 0.0:
            # The last piece of a dt: take what is left rather than leave a sliver of rounding.
            h = remaining if h >= remaining * (1.0 - 1e-9) else h
            k2, _ = self._rate(rate, np.array([x[0] + h * v1[0], x[1] + h * v1[1], x[2] + h * v1[2]]))
            v2 = k2.tolist()
            change = [v2[0] - v1[0], v2[1] - v1[1], v2[2] - v1[2]]
            error = 0.5 * h * _norm(change, weights)
            speed = _norm(v1, _SETTLED)
            # At rest the rate is at its rounding floor, and its ratio means nothing.
            ratio = _norm(change, _SETTLED) / speed if speed > 1.0 else 0.0
            floor = h <= MIN_STEP_FRACTION * dt
            # lambda h scales with the step: what a full dt would have met, whatever h the error chose.
            full = ratio * dt / h
            self.peak_ratio = max(self.peak_ratio, full)
            stiff = stiff or full > STIFF_STEP_RATIO
            if ratio > STIFF_STEP_RATIO and not floor:
                self.rejected += 1
                h *= STABLE_STEP_TARGET / ratio
                continue
            if error > STEP_ERROR_TOLERANCE and not floor:
                self.rejected += 1
                h *= max(STEP_SHRINK, STEP_SAFETY * math.sqrt(STEP_ERROR_TOLERANCE / error))
                continue
            half = 0.5 * h
            x = [x[0] + half * (v1[0] + v2[0]), x[1] + half * (v1[1] + v2[1]), x[2] + half * (v1[2] + v2[2])]
            x[2] = math.remainder(x[2], 2 * math.pi) % (2 * math.pi)
            remaining -= h
            self.substeps += 1
            grow = STEP_GROWTH if error == 0.0 else STEP_SAFETY * math.sqrt(STEP_ERROR_TOLERANCE / error)
            if ratio > 0.0:  # keep the next step inside the margin too
                grow = min(grow, STIFF_STEP_RATIO / ratio)
            state.step = h = min(h * min(grow, STEP_GROWTH), dt)
            pose = np.array(x)
            k1, wrench = self._rate(rate, pose)
            v1 = k1.tolist()
        if stiff:
            self.stiff_steps += 1
        # Lists and copies: a caller may change its pose array in place (a placement), which must not match.
        state.rate, state.wrench, state.rate_pose, state.rate_floats = k1, wrench, x, v1
        if self._at_rest(state, pose, k1, v1, rate, weights):
            state.rest_pose = pose.copy()
        return pose, k1, wrench

    def _at_rest(
        self,
        state: BodyState,
        pose: np.ndarray,
        k1: np.ndarray,
        v1: list[float],
        rate: Rate,
        weights: tuple[float, ...],
    ) -> bool:
        """Whether the body at ``pose`` is within REST_TRAVEL of a stable equilibrium.

        ``k1`` is its velocity, ``v1`` the same in floats.
        """
        if not any(v1):
            return True  # no force at all: every further step is this pose, bit for bit
        if _norm(v1, _SETTLED) > 1.0:
            state.inverse_jacobian, state.unstable = None, False  # moving: judge J afresh when it settles
            return False
        if state.inverse_jacobian is None and not state.unstable:
            jacobian = np.empty((3, 3))
            for axis in range(3):
                offset = np.zeros(3)
                offset[axis] = REST_DIFFERENCE * weights[axis]
                k, _ = self._rate(rate, pose + offset)
                jacobian[:, axis] = (k - k1) / offset[axis]
            # In the pose scale, where the modes of a part of any size compare.
            w = np.array(weights)
            scaled = jacobian * w[None, :] / w[:, None]
            eigenvalues = np.linalg.eigvals(scaled).real
            fastest = float(np.max(np.abs(eigenvalues)))
            if fastest == 0.0 or float(np.max(eigenvalues)) >= -REST_NEUTRAL * fastest:
                state.unstable = True
                return False
            state.inverse_jacobian = np.linalg.inv(jacobian)
        if state.unstable or state.inverse_jacobian is None:
            return False
        return _norm((state.inverse_jacobian @ k1).tolist(), weights) <= REST_TRAVEL


def _same_pose(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two poses (3,) are equal, element by element (np.array_equal at a fraction of its cost)."""
    return bool(a.tolist() == b.tolist())


def _norm(vector: list[float], scale: tuple[float, ...]) -> float:
    """Return |vector / scale| for a velocity or pose change of three components, in floats."""
    return math.hypot(vector[0] / scale[0], vector[1] / scale[1], vector[2] / scale[2])


def _same(a: tuple[object, ...], b: tuple[object, ...]) -> bool:
    """Whether two condition tuples name the same motion law (identical objects or equal values)."""
    if len(a) != len(b):
        return False
    # The same objects step after step (the usual case): one pass of identity tests, no comparisons.
    return all(map(operator.is_, a, b)) or all(
        x is y or (type(x) is type(y) and _equal(x, y)) for x, y in zip(a, b, strict=True)
    )


def _equal(x: object, y: object) -> bool:
    try:
        return bool(x == y)
    except ValueError:  # objects holding arrays: only the same object counts as the same
        return False
