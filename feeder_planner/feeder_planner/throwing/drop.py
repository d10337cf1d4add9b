"""Drop distributions of a planar part: on which hull edge a part dropped at a random orientation rests.

Two fidelities answer it. This module holds the quasi-static one and the distribution type both return;
the ``dynamic`` fidelity (random pymunk drops, tabulated and cached) is ``feeder_sim.throwing.drop``'s.

Quasi-static (``quasi_static``). Let psi be the direction of gravity in the part frame and

    r(psi) = max_k  v_k . (cos psi, sin psi)                                                    (D1)

the part's radius function: the height of the centre of mass above the support line when the part
touches it with gravity along psi (v_k the convex hull's vertices, centroid at the origin). A part
released at rest rolls quasi-statically down r: it comes to rest at the local minimum of r whose basin
holds psi. The minima are the stable edges (the normal of edge i, nu_i = alpha_i - pi/2, with the centre
of mass projecting inside the edge: u_l^i < 0 < u_r^i); the maxima are the vertex directions
beta_k = atan2(v_k) that lie inside their own normal cone [nu_{k-1}, nu_k], which is

    u_r^{k-1} > 0  and  u_l^k < 0                                                               (D2)

(r'(psi) = v_k . t_j at nu_j, t_j the direction of edge j). Edge i's capture interval runs from the
last maximum at or before vertex i to the first at or after vertex i + 1, and with psi uniform

    P(i) = (beta_b - beta_a) mod 2 pi / (2 pi)                                                 (D3)

for a stable edge, 0 for an unstable one. It is exact for the model (no sampling), and it leaves out
the momentum a falling part pivots over a vertex with: where a basin is shallow the dynamic share
differs (docs/experiments.md: the bracket's short edge).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from feeder_planner.throwing.geometry import ArmPart

__all__ = [
    "DROP_FIDELITIES",
    "DropDistribution",
    "capture_intervals",
    "quasi_static_drop",
    "radius_function",
]

# The fidelities a drop distribution can be computed at; the first is the default (docs/experiments.md).
DROP_FIDELITIES: tuple[str, ...] = ("quasi_static", "dynamic")

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class DropDistribution:
    """P(part rests on hull edge i) for i over the hull, and how it was obtained.

    ``samples`` is 0 for an exact (quasi-static) distribution; for a sampled one ``counts`` are the drops
    that ended on each edge, and ``standard_error`` the binomial standard error of each share.
    ``settings`` are the fidelity's parameters (drop height, friction...), JSON-ready.
    """

    fidelity: str
    probabilities: np.ndarray  # (n,) over the hull's edges, sums to 1
    samples: int = 0
    counts: np.ndarray | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    intervals: tuple[tuple[float, float] | None, ...] = ()  # quasi-static: each edge's (start, end) of psi

    @property
    def standard_error(self) -> np.ndarray:
        """Binomial standard error sqrt(p (1 - p) / N) per edge; zeros for an exact distribution."""
        p = self.probabilities
        if self.samples <= 0:
            return np.zeros_like(p)
        return np.sqrt(p * (1.0 - p) / self.samples)

    @property
    def edges(self) -> list[int]:
        """The edges a drop can end on (probability > 0)."""
        return [int(i) for i in np.flatnonzero(self.probabilities > 0.0)]

    def draw(self, rng: np.random.Generator) -> int:
        """Draw one resting edge (one uniform number from ``rng`` per draw, whatever the distribution)."""
        cumulative = np.cumsum(self.probabilities)
        u = float(rng.random()) * float(cumulative[-1])
        index = int(np.searchsorted(cumulative, u, side="right"))
        return min(index, len(cumulative) - 1)

    def to_json(self) -> dict[str, Any]:
        """Return the distribution as a JSON object (probabilities and standard errors per edge)."""
        return {
            "fidelity": self.fidelity,
            "probabilities": [float(p) for p in self.probabilities],
            "standard_error": [float(s) for s in self.standard_error],
            "samples": self.samples,
            "counts": None if self.counts is None else [int(c) for c in self.counts],
            "settings": dict(self.settings),
        }


def radius_function(part: ArmPart, psi: np.ndarray) -> np.ndarray:
    """Return r(psi) of eq. (D1) (m): the centre of mass's height over the support line, gravity along psi."""
    directions = np.stack((np.cos(psi), np.sin(psi)), axis=-1)
    return np.max(directions @ part.hull.T, axis=-1)


def _maxima(part: ArmPart) -> np.ndarray:
    """Return whether each hull vertex k is a local maximum of r (eq. D2)."""
    return (np.roll(part.u_right, 1) > 0.0) & (part.u_left < 0.0)


def capture_intervals(part: ArmPart) -> tuple[tuple[float, float] | None, ...]:
    """Return each edge's capture interval (psi_start, psi_end), counter-clockwise; None if unstable.

    psi_end - psi_start (mod 2 pi) is the interval's width; a part with one maximum only has a stable edge
    whose interval is the whole circle (end = start + 2 pi).
    """
    n = part.n
    maxima = np.flatnonzero(_maxima(part))
    beta = np.arctan2(part.hull[:, 1], part.hull[:, 0])
    result: list[tuple[float, float] | None] = []
    for i in range(n):
        if not part.stable[i]:
            result.append(None)
            continue
        # the last maximum at or before vertex i, the first at or after vertex i + 1 (cyclically)
        before = int(min(maxima, key=lambda k: (i - k) % n))
        after = int(min(maxima, key=lambda k: (k - i - 1) % n))
        start = float(beta[before])
        width = (float(beta[after]) - start) % TWO_PI
        if maxima.size == 1 or width == 0.0:
            width = TWO_PI
        result.append((start, start + width))
    return tuple(result)


def quasi_static_drop(part: ArmPart) -> DropDistribution:
    """Return the quasi-static drop distribution: each stable edge's capture width over 2 pi (eq. D3)."""
    intervals = capture_intervals(part)
    probabilities = np.array([0.0 if iv is None else (iv[1] - iv[0]) / TWO_PI for iv in intervals])
    return DropDistribution("quasi_static", probabilities, intervals=intervals)
