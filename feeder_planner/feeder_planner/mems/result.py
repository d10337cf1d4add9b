"""Equilibria results shared by the asymptotic, numeric and auto methods (contract section 3).

Results are frozen dataclasses; ``to_json()`` gives the contract's ``equilibria --json`` object (SI
units), the only place they become dicts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, get_args

from feeder_planner.errors import InputError

__all__ = [
    "Method",
    "SolvingMethod",
    "METHODS",
    "check_method",
    "Equilibrium",
    "NumericDetails",
    "AsymptoticDetails",
    "AutoChoice",
    "EquilibriaResult",
]

# The methods a caller may ask for: 'auto' picks one of the two that actually solve (issue item d).
Method = Literal["auto", "asymptotic", "numeric"]
SolvingMethod = Literal["asymptotic", "numeric"]
METHODS: tuple[Method, ...] = get_args(Method)


def check_method(method: object, field: str = "method") -> Method:
    """Return ``method`` if it is one of METHODS, else raise InputError naming ``field``."""
    for known in METHODS:
        if method == known:
            return known
    raise InputError(field, f"unknown method {method!r} (expected one of {', '.join(METHODS)})")


@dataclass(frozen=True)
class Equilibrium:
    """One equilibrium configuration (x, y, theta) of the part in the plane frame."""

    x: float
    y: float
    theta: float
    stable: bool

    def to_json(self) -> dict[str, Any]:
        """Return the contract's equilibrium object: x, y (m), theta in [0, 2 pi) (rad), stable."""
        return {
            "x": self.x + 0.0,  # + 0.0 turns -0.0 into 0.0
            "y": self.y + 0.0,
            "theta": self.theta % (2 * math.pi),
            "stable": self.stable,
        }


@dataclass(frozen=True)
class NumericDetails:
    """How the numeric method (zero crossings of x*, Prop. 6) resolved its equilibria."""

    samples: int  # theta samples of x* after subdivision
    x_resolution: float  # |x*| below this (m) is indistinguishable from 0
    hessian_min_eigenvalues: tuple[float, ...]  # smallest eigenvalue of Hess U(x, y, theta) per root
    theta_uncertainty: float  # bound on the error of every theta (rad)

    def to_json(self) -> dict[str, Any]:
        """Return the details' numeric entries in the order of the JSON object."""
        return {
            "samples": self.samples,
            "x_resolution": self.x_resolution,
            "hessian_min_eigenvalues": list(self.hessian_min_eigenvalues),
            "theta_uncertainty": self.theta_uncertainty,
        }


@dataclass(frozen=True)
class AsymptoticDetails:
    """What Table 1 and Theorem 7 found: the order n and the roots of d^n x*/d delta^n (theta, 0)."""

    n: int  # order of the first d^n x*/d delta^n (theta, 0) not identically zero
    pivot_distance: float  # |(X0, Y0)| (m): pivot to centroid
    theorem7_roots: tuple[float, ...]  # roots of d^n x*/d delta^n (theta, 0) (rad)
    theorem7_slopes: tuple[float, ...]  # its theta-derivative at each root (> 0: stable)
    dn_x_fourier: tuple[tuple[int, float], ...]  # (frequency, amplitude) of d^n x*/d delta^n
    stable_limit_theta: float | None = None  # n = 0: the limit 3 pi/2 - psi of the stable theta

    def to_json(self, certified: bool) -> dict[str, Any]:
        """Return the details' asymptotic entries in the order of the JSON object."""
        out: dict[str, Any] = {
            "n": self.n,
            "certified": certified,
            "pivot_distance": self.pivot_distance,
            "theorem7_roots": list(self.theorem7_roots),
            "theorem7_slopes": list(self.theorem7_slopes),
            "dn_x_fourier": {str(k): a for k, a in self.dn_x_fourier},
        }
        if self.stable_limit_theta is not None:
            out["stable_limit_theta"] = self.stable_limit_theta
        return out


@dataclass(frozen=True)
class AutoChoice:
    """Why 'auto' returned the method it did."""

    certified_at_delta: float | None = None  # asymptotic: where the numeric method confirmed it
    numeric_refused: str | None = None  # asymptotic certified elsewhere: the numeric refusal at delta
    asymptotic_refused: str | None = None  # numeric: the asymptotic refusal
    asymptotic_disagreed: bool = False  # numeric: the asymptotic answer did not match

    def to_json(self) -> dict[str, Any]:
        """Return the details' auto entries in the order of the JSON object, ending with 'requested'."""
        out: dict[str, Any] = {}
        if self.certified_at_delta is not None:
            out["certified_at_delta"] = self.certified_at_delta
        if self.numeric_refused is not None:
            out["numeric_refused"] = self.numeric_refused
        if self.asymptotic_refused is not None:
            out["asymptotic_refused"] = self.asymptotic_refused
        if self.asymptotic_disagreed:
            out["asymptotic_disagreed"] = True
        out["requested"] = "auto"
        return out


@dataclass(frozen=True)
class EquilibriaResult:
    """All equilibria of a part for one delta, the pivot point (part frame) and how they were found.

    Exactly one of ``numeric`` and ``asymptotic`` is set, the one of ``method``; ``auto`` is set when
    the caller asked for 'auto'. ``certified`` is False only for an explicit asymptotic answer, which
    Theorem 7 guarantees for delta below an unknown delta_0 only.
    """

    pivot: tuple[float, float]
    area: float
    delta: float
    method: SolvingMethod
    equilibria: tuple[Equilibrium, ...]
    certified: bool
    numeric: NumericDetails | None = None
    asymptotic: AsymptoticDetails | None = None
    auto: AutoChoice | None = None

    @property
    def stable(self) -> tuple[Equilibrium, ...]:
        """Return the stable equilibria."""
        return tuple(e for e in self.equilibria if e.stable)

    def details_json(self) -> dict[str, Any]:
        """Return the JSON object's ``details``: certification and method data."""
        out: dict[str, Any] = {}
        if self.asymptotic is not None:
            out.update(self.asymptotic.to_json(self.certified))
        if self.numeric is not None:
            out["certified"] = self.certified
            out.update(self.numeric.to_json())
        if self.auto is not None:
            out.update(self.auto.to_json())
        return out

    def to_json(self) -> dict[str, Any]:
        """Return the contract's ``equilibria --json`` object (SI units, theta in [0, 2 pi))."""
        return {
            "pivot": [self.pivot[0] + 0.0, self.pivot[1] + 0.0],
            "area": self.area,
            "delta": self.delta,
            "method": self.method,
            "equilibria": [e.to_json() for e in self.equilibria],
            "details": self.details_json(),
        }
