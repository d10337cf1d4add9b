"""Equilibria results shared by the asymptotic, numeric and auto methods (contract section 3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Equilibrium:
    """One equilibrium configuration (x, y, theta) of the part in the plane frame."""

    x: float
    y: float
    theta: float
    stable: bool

    def to_dict(self) -> dict[str, Any]:
        return {
            "x": self.x + 0.0,
            "y": self.y + 0.0,
            "theta": self.theta % (2 * math.pi),
            "stable": self.stable,
        }


@dataclass(frozen=True)
class EquilibriaResult:
    """All equilibria of a part for one delta, the pivot point (part frame) and how they were found."""

    pivot: tuple[float, float]
    area: float
    delta: float
    method: str
    equilibria: tuple[Equilibrium, ...]
    details: dict[str, Any] = field(default_factory=dict)

    @property
    def stable(self) -> tuple[Equilibrium, ...]:
        return tuple(e for e in self.equilibria if e.stable)

    def to_dict(self) -> dict[str, Any]:
        return {
            "pivot": [self.pivot[0] + 0.0, self.pivot[1] + 0.0],
            "area": self.area,
            "delta": self.delta,
            "method": self.method,
            "equilibria": [e.to_dict() for e in self.equilibria],
            "details": self.details,
        }
