"""The squeeze function and the part's symmetry (Goldberg 1993, section 3).

A frictionless, quasi-static squeeze rotates the part so that the jaw width decreases, until the width is
a local minimum of the diameter function: the part at orientation theta relative to the gripper ends at
the minimum of the basin holding theta. The squeeze function s maps theta to that minimum; it is a step
function, monotone in its lift, with s(theta + pi) = s(theta) + pi.

Steps are half-open, [m_j, m_{j+1}) -> f_j, with m_j the maxima and f_j the minima: a part exactly at an
unstable equilibrium (a maximum, a set of measure zero) is taken to fall towards increasing theta.

The squeeze function's symmetry period T = pi / k is the smallest shift mapping its steps onto themselves;
a plan of squeezes can orient a part only up to T (Goldberg's "up to symmetry"). The hull's own
rotational symmetry of order r gives T <= pi / (r / gcd(r, 2)) (a square: pi/2, an equilateral triangle:
pi/3), and T may be smaller than the hull's symmetry implies.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from feeder_planner.errors import InputError
from feeder_planner.fields_io import finite_number
from feeder_planner.squeeze.diameter import DiameterFunction, diameter_function, wrap
from feeder_planner.squeeze.tolerances import ANGLE_TOLERANCE

__all__ = ["SqueezeFunction", "hull_symmetry_order", "squeeze_function"]


@dataclass(frozen=True)
class SqueezeFunction:
    """s over one period pi: steps [maxima[j], maxima[j+1]) -> minima[j], lifted so maxima[0] < ... .

    ``maxima`` and ``minima`` have the same length N; maxima[j] < minima[j] < maxima[j+1] with
    maxima[N] = maxima[0] + pi. ``period`` is the symmetry period T = pi / ``symmetry``.
    """

    diameter: DiameterFunction
    maxima: tuple[float, ...]
    minima: tuple[float, ...]
    symmetry: int

    @property
    def period(self) -> float:
        """The symmetry period T (rad): s(theta + T) = s(theta) + T."""
        return math.pi / self.symmetry

    def __call__(self, theta: float) -> float:
        """Return the orientation after a squeeze from ``theta`` (rad, any real; the result in its lift)."""
        x = self.maxima[0] + wrap(theta - self.maxima[0], math.pi)
        j = bisect.bisect_right(self.maxima, x) - 1
        return theta + (self.minima[j] - x)

    def step_of(self, theta: float) -> int:
        """Return the index j of the step holding ``theta`` (mod pi)."""
        x = self.maxima[0] + wrap(theta - self.maxima[0], math.pi)
        return bisect.bisect_right(self.maxima, x) - 1

    @cached_property
    def _offsets(self) -> list[float]:
        """The step boundaries from maxima[0], with pi closing the period (made once)."""
        return [m - self.maxima[0] for m in self.maxima] + [math.pi]

    def boundary_distance(self, theta: float) -> float:
        """Distance (rad) from ``theta`` to the nearest unstable orientation (a step boundary)."""
        x = wrap(theta - self.maxima[0], math.pi)
        offsets = self._offsets
        j = bisect.bisect_right(offsets, x) - 1
        return min(x - offsets[j], offsets[j + 1] - x)

    def steps_per_period(self) -> int:
        """Return the number n of steps in one symmetry period T."""
        return len(self.minima) // self.symmetry

    def period_steps(self) -> tuple[np.ndarray, np.ndarray]:
        """Boundaries m_0..m_n (m_n = m_0 + T) and fixed points f_0..f_{n-1} of one symmetry period."""
        n = self.steps_per_period()
        bounds = np.array([*self.maxima[:n], self.maxima[0] + self.period])
        return bounds, np.array(self.minima[:n])

    def width_after(self, theta: float) -> float:
        """Return the jaw width (m) the jaw-width sensor reads after a squeeze from ``theta``."""
        return self.diameter(self(theta))


def _symmetry(maxima: list[float], minima: list[float]) -> int:
    """Return the largest k with both step sets invariant under a shift of pi / k."""
    count = len(minima)
    for k in range(count, 1, -1):
        if count % k:
            continue
        shift = count // k
        ok = all(
            abs(math.remainder(values[(j + shift) % count] - values[j] - math.pi / k, math.pi))
            <= 10 * ANGLE_TOLERANCE
            for values in (maxima, minima)
            for j in range(count)
        )
        if ok:
            return k
    return 1


def squeeze_function(vertices: object, field: str = "vertices") -> SqueezeFunction:
    """Build the squeeze function of a part outline (its hull); refuses a degenerate hull naming ``field``."""
    diameter = diameter_function(vertices, field)
    maxima = [e.angle for e in diameter.maxima]
    minima_raw = [e.angle for e in diameter.minima]
    base = maxima[0]
    lifted_max = [base + wrap(m - base, math.pi) for m in maxima]
    lifted_min = sorted(base + wrap(f - base, math.pi) for f in minima_raw)
    # Minima and maxima alternate: each minimum lies after its step's maximum and before the next one.
    bounds = [*lifted_max, base + math.pi]
    for j, f in enumerate(lifted_min):
        if not bounds[j] < f < bounds[j + 1]:
            raise InputError(field, f"the diameter function's extrema do not alternate at {f:.6f} rad")
    return SqueezeFunction(
        diameter=diameter,
        maxima=tuple(lifted_max),
        minima=tuple(lifted_min),
        symmetry=_symmetry(lifted_max, lifted_min),
    )


def hull_symmetry_order(hull: np.ndarray, tolerance: float = 1e-9) -> int:
    """Return the order r of the hull's rotational symmetry about its centroid (1 if none).

    A rotation by 2 pi / r maps the vertex set onto itself; checked for every r dividing the count.
    """
    n = len(hull)
    centred = hull - hull.mean(axis=0)
    scale = float(np.abs(centred).max())
    for r in range(n, 1, -1):
        if n % r:
            continue
        c, s = math.cos(2 * math.pi / r), math.sin(2 * math.pi / r)
        turned = centred @ np.array([[c, -s], [s, c]]).T
        gaps = np.linalg.norm(turned[:, None, :] - centred[None, :, :], axis=2).min(axis=1)
        if float(gaps.max()) <= tolerance * scale:
            return r
    return 1


def check_angle(value: object, field: str) -> float:
    """Return a squeeze angle (rad): a finite number; refused naming ``field`` otherwise."""
    return finite_number(value, field)
